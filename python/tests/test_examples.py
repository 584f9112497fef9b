"""The examples run (short versions) and say what they claim."""
import importlib.util
import json
import os
import subprocess
import sys

import pytest

EXAMPLES = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "examples")


def run(script, *args):
    return subprocess.run([sys.executable, os.path.join(EXAMPLES, script), *args], capture_output=True, text=True,
                          timeout=300, env=dict(os.environ))


def test_random_safety_check_finds_no_collision_under_atacom():
    r = run("random_safety_check.py", "--env", "table", "nav", "--envs", "8", "--steps", "800")
    assert r.returncode == 0, r.stdout + r.stderr
    assert "ATACOM: no collisions" in r.stdout
    assert r.stdout.count("atacom") == 2 and r.stdout.count("none") == 2


def test_sac_torch_example_runs_or_skips_cleanly():
    r = run("sac_torch.py", "--steps", "240", "--warmup", "160", "--envs", "4", "--hidden", "32", "--batch", "16",
            "--log-every", "120")
    assert r.returncode == 0, r.stdout + r.stderr
    if importlib.util.find_spec("torch") is None:
        assert "skipped: PyTorch is not installed" in r.stdout
        pytest.skip("PyTorch not installed: the example skipped cleanly")
    assert '"train_collisions": 0' in r.stdout and '"updates": ' in r.stdout


def test_sac_torch_example_without_torch_says_so(tmp_path):
    (tmp_path / "torch.py").write_text("raise ImportError('no torch here')\n")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(tmp_path), os.environ.get("PYTHONPATH", "")]))
    r = subprocess.run([sys.executable, os.path.join(EXAMPLES, "sac_torch.py")], capture_output=True, text=True,
                       timeout=60, env=env)
    assert r.returncode == 0
    assert "sac_torch.py skipped: PyTorch is not installed (Debian: apt-get install python3-torch)" in r.stdout


def test_hri_upright_probe_keeps_the_cup_upright():
    r = run("hri_upright_probe.py", "--episodes", "1", "--steps", "30")
    assert r.returncode == 0, r.stdout + r.stderr
    assert "episodes above 25 deg: 0 of 1" in r.stdout


def tiny_run(tmp_path, cli, env):
    """A 128-step atacom-ppo run on env (too short to learn): a run directory for the examples that read one."""
    cfg = tmp_path / f"{env}.json"
    cfg.write_text(json.dumps({"ppo": {"actor": {"hidden": [8]}, "critic": {"hidden": [8]}, "minibatch_size": 32},
                               "train": {"env": env, "algo": "atacom-ppo", "steps": 128, "num_envs": 4,
                                         "eval_every": 128, "eval_episodes": 1}}))
    rc, _, err = cli(["--threads", "1", "train", "--config", str(cfg), "--out", str(tmp_path / "run")])
    assert rc == 0, err
    return str(tmp_path / "run")


def test_hri_tilt_trace_reads_a_run(tmp_path, cli):
    r = run("hri_tilt_trace.py", tiny_run(tmp_path, cli, "hri"), "--episodes", "2", "--steps", "12")
    assert r.returncode == 0, r.stdout + r.stderr
    assert "of 2; above 15 deg:" in r.stdout and "t= 10" in r.stdout


def test_near_rows_reads_a_run(tmp_path, cli):
    run_dir = tiny_run(tmp_path, cli, "table")
    r = run("near_rows.py", run_dir, "--episodes", "2", "--steps", "12", "--from-step", "4", "--top", "3")
    assert r.returncode == 0, r.stdout + r.stderr
    lines = r.stdout.splitlines()
    assert lines[0].startswith("atacom-ppo on table, 2 episodes, steps 4-11: share of steps with the row within 0.05")
    assert len(lines) >= 5 and all("mean c" in line for line in lines[1:4])
    assert lines[4].startswith("final distance: mean ")
    r = run("near_rows.py", run_dir, "--episodes", "2", "--steps", "12", "--from-step", "12")
    assert r.returncode != 0 and "--from-step is 12, must be in [0, 11]" in r.stderr


def test_same_run_tells_a_rerun_from_a_different_run(tmp_path, cli):
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir()
    b.mkdir()
    run_a, run_b = tiny_run(a, cli, "table"), tiny_run(b, cli, "table")
    r = run("same_run.py", run_b, run_a)
    assert r.returncode == 0 and "1 of 1 the same" in r.stdout, r.stdout + r.stderr
    # a wall time differs: still the same run; a learning number differs: not
    summary = json.loads(open(os.path.join(run_b, "summary.json")).read())
    summary["wall_s"] = summary["wall_s"] + 1.0
    open(os.path.join(run_b, "summary.json"), "w").write(json.dumps(summary))
    assert run("same_run.py", run_b, run_a).returncode == 0
    summary["eval_return_mean"] = summary["eval_return_mean"] + 1e-9
    open(os.path.join(run_b, "summary.json"), "w").write(json.dumps(summary))
    r = run("same_run.py", run_b, run_a)
    assert r.returncode == 1 and "DIFFERENT: summary.json eval_return_mean" in r.stdout, r.stdout
