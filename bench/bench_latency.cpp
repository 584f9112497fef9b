// Latency of one safety-filter call for one robot (N = 1), as a controller
// embedding the projector sees it: percentiles over many calls, not a rate.
//
//   {"bench": "projector_latency", "via": "in_process", "k", "m", "n", "calls", "threads",
//    "p50_us", "p99_us", "max_us", "mean_us"}
//       project_batch() on a one-env batch (the library call), each call timed
//       alone with steady_clock; the inputs change every call (a pool of 64
//       random problems, copied in untimed), so no call repeats the last.
//   {"bench": "projector_latency", "via": "filter_pipe", ...the same keys}
//       one request/response of `atacom filter` over a pipe (write a JSON line,
//       read the answer line): JSON encode in this process, the filter's parse,
//       projection and encode, two pipe hops.
// (k, m) = (34, 7): the TIAGo arm's table constraints, n = 7; (5, 2): a
// differential drive among walls, n = 3. Dense G with drift, as the filter.
//
// Usage: bench_latency [--calls C] [--filter-calls F] [--atacom PATH]
//   PATH: the atacom executable (default: ../atacom next to this binary's folder)
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <stdexcept>
#include <string>
#include <vector>

#include "atacom/parallel.hpp"
#include "atacom/projector.hpp"
#include "atacom/rng.hpp"
#include "bench_common.hpp"

using namespace atacom;

namespace {

struct Problem {
  std::vector<double> f, G, Jq, c, alpha;
};

std::vector<Problem> make_pool(int n, int m, int k, int count, uint64_t seed) {
  Rng rng(seed, 0);
  std::vector<Problem> pool(count);
  for (Problem& p : pool) {
    p.f.resize(n);
    p.G.resize(size_t(n) * m);
    p.Jq.resize(size_t(k) * n);
    p.c.resize(k);
    p.alpha.resize(m);
    for (auto& v : p.f) v = 0.3 * rng.normal();
    for (auto& v : p.G) v = rng.normal();
    for (auto& v : p.Jq) v = rng.normal();
    for (auto& v : p.c) v = rng.uniform(-1.0, 0.05);  // inactive, active and violated rows
    for (auto& v : p.alpha) v = rng.uniform(-1.0, 1.0);
  }
  return pool;
}

nlohmann::json stats(std::vector<double> us) {
  std::sort(us.begin(), us.end());
  auto pct = [&](double q) { return us[std::min(us.size() - 1, size_t(q * double(us.size())))]; };
  double sum = 0;
  for (double v : us) sum += v;
  return {{"calls", us.size()}, {"p50_us", pct(0.50)}, {"p99_us", pct(0.99)}, {"max_us", us.back()},
          {"mean_us", sum / double(us.size())}};
}

std::vector<double> time_in_process(int n, int m, int k, int calls) {
  const ProjectorModel model = default_projector_model(n, m, k);
  ProjectorBatch batch(model, 1);
  const std::vector<Problem> pool = make_pool(n, m, k, 64, 7);
  std::vector<double> us;
  us.reserve(calls);
  const int warm = std::min(calls, 1000);
  for (int i = 0; i < warm + calls; ++i) {
    const Problem& p = pool[i % pool.size()];
    std::copy(p.f.begin(), p.f.end(), batch.f.begin());
    std::copy(p.G.begin(), p.G.end(), batch.G.begin());
    std::copy(p.Jq.begin(), p.Jq.end(), batch.Jq.begin());
    std::copy(p.c.begin(), p.c.end(), batch.c.begin());
    std::copy(p.alpha.begin(), p.alpha.end(), batch.alpha.begin());
    const auto t0 = std::chrono::steady_clock::now();
    project_batch(model, batch);
    const auto t1 = std::chrono::steady_clock::now();
    if (i >= warm) us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
  }
  return us;
}

std::string request_line(const Problem& p, int n, int m, int k, int id) {
  auto rows = [](const std::vector<double>& v, int r, int c) {
    nlohmann::json out = nlohmann::json::array();
    for (int i = 0; i < r; ++i) out.push_back(std::vector<double>(v.begin() + size_t(i) * c, v.begin() + size_t(i + 1) * c));
    return out;
  };
  nlohmann::json j = {{"f", p.f}, {"G", rows(p.G, n, m)}, {"J_q", rows(p.Jq, k, n)}, {"c", p.c},
                      {"alpha", p.alpha}, {"id", id}};
  return j.dump() + "\n";
}

// `atacom filter` as a child process: requests on its stdin, answers on its stdout.
class FilterProcess {
 public:
  explicit FilterProcess(const std::string& exe) {
    int in[2], out[2];
    if (pipe(in) != 0 || pipe(out) != 0) throw std::runtime_error("pipe failed");
    pid_ = fork();
    if (pid_ < 0) throw std::runtime_error("fork failed");
    if (pid_ == 0) {
      dup2(in[0], 0);
      dup2(out[1], 1);
      close(in[0]), close(in[1]), close(out[0]), close(out[1]);
      execl(exe.c_str(), exe.c_str(), "filter", static_cast<char*>(nullptr));
      _exit(127);
    }
    close(in[0]);
    close(out[1]);
    to_ = in[1];
    from_ = out[0];
  }
  ~FilterProcess() {
    close(to_);
    close(from_);
    int st = 0;
    waitpid(pid_, &st, 0);
  }
  // One request line in, one answer line out.
  std::string call(const std::string& line) {
    for (size_t done = 0; done < line.size();) {
      const ssize_t w = write(to_, line.data() + done, line.size() - done);
      if (w <= 0) throw std::runtime_error("atacom filter: write failed");
      done += size_t(w);
    }
    std::string answer;
    for (;;) {
      const size_t nl = buf_.find('\n');
      if (nl != std::string::npos) {
        answer = buf_.substr(0, nl);
        buf_.erase(0, nl + 1);
        return answer;
      }
      char chunk[65536];
      const ssize_t r = read(from_, chunk, sizeof chunk);
      if (r <= 0) throw std::runtime_error("atacom filter: no answer (exited?)");
      buf_.append(chunk, size_t(r));
    }
  }

 private:
  pid_t pid_ = -1;
  int to_ = -1, from_ = -1;
  std::string buf_;
};

std::vector<double> time_filter(const std::string& exe, int n, int m, int k, int calls) {
  const std::vector<Problem> pool = make_pool(n, m, k, 64, 7);
  std::vector<std::string> lines;
  for (size_t i = 0; i < pool.size(); ++i) lines.push_back(request_line(pool[i], n, m, k, int(i)));
  FilterProcess filter(exe);
  std::vector<double> us;
  us.reserve(calls);
  const int warm = std::min(calls, 200);
  for (int i = 0; i < warm + calls; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    const std::string answer = filter.call(lines[i % lines.size()]);
    const auto t1 = std::chrono::steady_clock::now();
    if (answer.find("\"error\"") != std::string::npos) throw std::runtime_error("atacom filter: " + answer);
    if (i >= warm) us.push_back(std::chrono::duration<double, std::micro>(t1 - t0).count());
  }
  return us;
}

}  // namespace

int main(int argc, char** argv) {
  int calls = 100000, filter_calls = 5000;
  std::string exe;
  for (int i = 1; i < argc; ++i) {
    const bool has_value = i + 1 < argc;
    if (!std::strcmp(argv[i], "--calls") && has_value) {
      calls = bench::flag_value<int>("--calls", argv[++i], range::closed(1, 100'000'000));
    } else if (!std::strcmp(argv[i], "--filter-calls") && has_value) {
      filter_calls = bench::flag_value<int>("--filter-calls", argv[++i], range::closed(0, 10'000'000));
    } else if (!std::strcmp(argv[i], "--atacom") && has_value) {
      exe = argv[++i];
    } else {
      std::fprintf(stderr, "usage: bench_latency [--calls C] [--filter-calls F] [--atacom PATH]\n");
      return 2;
    }
  }
  if (exe.empty()) {
    std::error_code ec;
    exe = (std::filesystem::read_symlink("/proc/self/exe", ec).parent_path().parent_path() / "atacom").string();
  }
  const std::string cpu = bench::cpu_name();
  struct Case { int k, m, n; };
  for (const Case& c : {Case{34, 7, 7}, Case{5, 2, 3}}) {
    nlohmann::json j = {{"bench", "projector_latency"}, {"via", "in_process"}, {"k", c.k}, {"m", c.m},
                        {"n", c.n}, {"threads", num_threads()}};
    j.update(stats(time_in_process(c.n, c.m, c.k, calls)));
    j["cpu"] = cpu;
    bench::emit(j);
  }
  if (filter_calls > 0) {
    if (access(exe.c_str(), X_OK) != 0) {
      std::fprintf(stderr, "bench_latency: %s is not executable; skipping the filter (pass --atacom PATH)\n",
                   exe.c_str());
      return 0;
    }
    for (const Case& c : {Case{34, 7, 7}, Case{5, 2, 3}}) {
      nlohmann::json j = {{"bench", "projector_latency"}, {"via", "filter_pipe"}, {"k", c.k}, {"m", c.m},
                          {"n", c.n}};
      j.update(stats(time_filter(exe, c.n, c.m, c.k, filter_calls)));
      j["cpu"] = cpu;
      bench::emit(j);
    }
  }
  return 0;
}
