// The HTML page of `atacom render`: style, markup and the script that draws
// the episode's data (render.cpp) into SVG views and moves them with the
// slider. Self-contained: no external file, font or script.
#include <string>

#include "src/experiments/render.hpp"
#include "src/core/svg.hpp"

namespace atacom {

namespace {

const char* kStyle = R"CSS(
body { font-family: sans-serif; margin: 16px; color: #222; }
h1 { font-size: 16px; font-weight: normal; }
.views { display: flex; flex-wrap: wrap; gap: 12px; }
.view { border: 2px solid #dee2e6; background: #fff; }
.view.hit { border-color: #e03131; }
.view.limit { border-color: #f08c00; }
.vname { font-size: 12px; color: #555; }
.controls { margin: 10px 0; display: flex; align-items: center; gap: 12px; }
#slider { width: 640px; }
#status { font-family: monospace; font-size: 13px; white-space: pre; }
.legend span { display: inline-block; margin-right: 14px; font-size: 12px; }
.legend i { display: inline-block; width: 14px; height: 10px; margin-right: 4px; vertical-align: middle; }
.obstacle { fill: #d8c9a8; stroke: #a68a5b; stroke-width: 1; vector-effect: non-scaling-stroke; }
.body { fill: #ced4da; stroke: #868e96; stroke-width: 1; vector-effect: non-scaling-stroke; }
.wall { fill: #868e96; }
.goal-region { fill: none; stroke: #e03131; stroke-width: 1.2; stroke-dasharray: 6 4; opacity: 0.6; vector-effect: non-scaling-stroke; }
.link { stroke: #4a6fa5; stroke-linecap: round; opacity: 0.85; }
.human { stroke: #e8590c; stroke-linecap: round; opacity: 0.5; }
.poi { fill: #2b8a3e; fill-opacity: 0.45; }
.margin { fill: none; stroke: #2b8a3e; stroke-width: 0.8; stroke-dasharray: 3 2; vector-effect: non-scaling-stroke; }
.tiago { fill: #4a6fa5; fill-opacity: 0.55; stroke: #1c3d6e; stroke-width: 1.5; vector-effect: non-scaling-stroke; }
.fetch { fill: #e8590c; fill-opacity: 0.55; stroke: #a33e05; stroke-width: 1.5; vector-effect: non-scaling-stroke; }
.heading { stroke: #222; stroke-width: 2; vector-effect: non-scaling-stroke; }
.goal { stroke: #e03131; stroke-width: 2.5; vector-effect: non-scaling-stroke; }
.axis { stroke: #7048e8; stroke-width: 2.5; vector-effect: non-scaling-stroke; }
.floor { stroke: #495057; stroke-width: 1.5; vector-effect: non-scaling-stroke; }
.cursor { stroke: #1c1c1c; stroke-width: 1; }
)CSS";

const char* kScript = R"JS(
(function () {
  const D = JSON.parse(document.getElementById('atacom-data').textContent);
  const SVGNS = 'http://www.w3.org/2000/svg';
  const W = 560, H = 420;
  const el = (tag, attrs, parent) => {
    const e = document.createElementNS(SVGNS, tag);
    for (const k in attrs) e.setAttribute(k, attrs[k]);
    if (parent) parent.appendChild(e);
    return e;
  };
  const views = [];
  const host = document.getElementById('views');
  for (const v of D.views) {
    const [u0, u1, v0, v1] = v.range;
    const s = Math.min(W / (u1 - u0), H / (v1 - v0));
    const w = Math.round((u1 - u0) * s), h = Math.round((v1 - v0) * s);
    const box = document.createElement('div');
    const name = document.createElement('div');
    name.className = 'vname';
    name.textContent = v.name + ' view (' + 'xyz'[v.u] + ' right, ' + 'xyz'[v.v] + ' up, m)';
    box.appendChild(name);
    const svg = el('svg', {width: w, height: h, viewBox: '0 0 ' + w + ' ' + h, class: 'view'});
    box.appendChild(svg);
    host.appendChild(box);
    // World (u, v) -> pixels: y points up.
    const g = el('g', {transform: 'matrix(' + s + ',0,0,' + (-s) + ',' + (-u0 * s) + ',' + (v1 * s) + ')'}, svg);
    views.push({svg, g, u: v.u, v: v.v, dyn: []});
  }
  // Static scene.
  const S = D.statics;
  for (const V of views) {
    const U = V.u, Vv = V.v;
    for (const r of S.regions) {
      if (r.min[Vv] === r.max[Vv] && Vv === 2) continue;
      el('rect', {x: r.min[U], y: r.min[Vv], width: r.max[U] - r.min[U], height: Math.max(r.max[Vv] - r.min[Vv], 1e-3), class: r.cls}, V.g);
    }
    for (const b of S.boxes)
      el('rect', {x: b.min[U], y: b.min[Vv], width: b.max[U] - b.min[U], height: b.max[Vv] - b.min[Vv], class: b.cls}, V.g);
    for (const c of S.cylinders) {
      if (Vv === 2) el('rect', {x: c.c[U] - c.r, y: c.z[0], width: 2 * c.r, height: c.z[1] - c.z[0], class: c.cls}, V.g);
      else el('circle', {cx: c.c[U], cy: c.c[Vv], r: c.r, class: c.cls}, V.g);
    }
    for (const c of S.spheres) el('circle', {cx: c.c[U], cy: c.c[Vv], r: c.r, class: c.cls}, V.g);
    for (const c of S.capsules)
      el('line', {x1: c.a[U], y1: c.a[Vv], x2: c.b[U], y2: c.b[Vv], 'stroke-width': 2 * c.r, class: c.cls}, V.g);
    if (Vv === 2) {
      const [u0, u1] = D.views[views.indexOf(V)].range;
      el('line', {x1: u0, y1: 0, x2: u1, y2: 0, class: 'floor'}, V.g);
    }
    // Moving elements, created once; human capsules first (drawn below the arm).
    const order = D.capsule_cls.map((c, i) => i).sort((a, b) => (D.capsule_cls[a] === 'human' ? 0 : 1) - (D.capsule_cls[b] === 'human' ? 0 : 1));
    V.cap = [];
    for (const i of order)
      V.cap[i] = el('line', {'stroke-width': 2 * D.capsule_radius[i], class: D.capsule_cls[i]}, V.g);
    V.sph = D.sphere_radius.map((r, i) => el('circle', {r: r, class: D.sphere_cls[i]}, V.g));
    V.mar = D.sphere_margin.map((r) => r > 0 ? el('circle', {r: r, class: 'margin'}, V.g) : null);
    V.disc = D.disc_radius.map((r, i) => [el('circle', {r: r, class: D.disc_cls[i]}, V.g), el('line', {class: 'heading'}, V.g)]);
    V.goal = [el('line', {class: 'goal'}, V.g), el('line', {class: 'goal'}, V.g)];
    V.axis = el('line', {class: 'axis'}, V.g);
    V.tip = el('circle', {r: 0.02, fill: '#7048e8'}, V.g);
  }
  const set = (e, a) => { for (const k in a) e.setAttribute(k, a[k]); };
  // Legend: only what this scene draws.
  const names = {obstacle: ['#d8c9a8', 'table / shelf'], body: ['#ced4da', 'robot body'], wall: ['#868e96', 'walls'],
                 link: ['#4a6fa5', 'arm links (capsules)'], poi: ['#2b8a3e', 'points of interest (dashed: row threshold)'],
                 human: ['#e8590c', 'human (capsules)'], tiago: ['#4a6fa5', 'TIAGo'], fetch: ['#e8590c', 'Fetch'],
                 'goal-region': ['#ffc9c9', 'goal region']};
  const used = new Set([...S.boxes, ...S.cylinders, ...S.spheres, ...S.regions].map((x) => x.cls)
                       .concat(D.capsule_cls, D.sphere_cls, D.disc_cls));
  const legend = document.getElementById('legend');
  const item = (color, text) => {
    const s = document.createElement('span');
    const i = document.createElement('i');
    i.style.background = color;
    s.appendChild(i);
    s.appendChild(document.createTextNode(text));
    legend.appendChild(s);
  };
  for (const k in names) if (used.has(k)) item(names[k][0], names[k][1]);
  item('#e03131', 'goal (x), collisions (red lines / border)');
  if (D.collision.some((c) => c === 2)) item('#f08c00', 'joint-limit violations (orange lines / border)');
  if (D.axis_label) item('#7048e8', D.axis_label);
  const span = Math.max(...D.views.map((v) => Math.max(v.range[1] - v.range[0], v.range[3] - v.range[2])));
  const T = D.steps;
  const slider = document.getElementById('slider');
  const status = document.getElementById('status');
  const cursors = Array.from(document.querySelectorAll('.plot svg')).map((svg) => {
    const h = +svg.getAttribute('height');
    return el('line', {x1: 0, x2: 0, y1: D.plot.margin, y2: h - D.plot.margin, class: 'cursor'}, svg);
  });
  const P = D.plot;
  function draw(i) {
    const f = i === 0 ? D.start : D.frames[i - 1];
    const ev = i > 0 ? D.collision[i - 1] : 0, hit = ev === 1;
    for (const V of views) {
      const U = V.u, Vv = V.v;
      V.svg.classList.toggle('hit', hit);
      V.svg.classList.toggle('limit', ev === 2);
      for (let c = 0; c < V.cap.length; ++c) {
        const p = f.cap.slice(6 * c, 6 * c + 6);
        set(V.cap[c], {x1: p[U], y1: p[Vv], x2: p[3 + U], y2: p[3 + Vv]});
      }
      for (let s = 0; s < V.sph.length; ++s) {
        const p = f.sph.slice(3 * s, 3 * s + 3);
        set(V.sph[s], {cx: p[U], cy: p[Vv]});
        if (V.mar[s]) set(V.mar[s], {cx: p[U], cy: p[Vv]});
      }
      for (let d = 0; d < V.disc.length; ++d) {
        const x = f.disc[3 * d], y = f.disc[3 * d + 1], th = f.disc[3 * d + 2], r = D.disc_radius[d];
        set(V.disc[d][0], {cx: x, cy: y});
        set(V.disc[d][1], {x1: x, y1: y, x2: x + r * Math.cos(th), y2: y + r * Math.sin(th)});
      }
      if (f.goal) {
        const gu = f.goal[U], gv = f.goal[Vv], k = 0.015 * span;
        set(V.goal[0], {x1: gu - k, y1: gv - k, x2: gu + k, y2: gv + k});
        set(V.goal[1], {x1: gu - k, y1: gv + k, x2: gu + k, y2: gv - k});
      }
      V.axis.style.display = V.tip.style.display = f.axis ? '' : 'none';
      if (f.axis) {
        const a = f.axis, L = 0.15;
        set(V.axis, {x1: a[U], y1: a[Vv], x2: a[U] + L * a[3 + U], y2: a[Vv] + L * a[3 + Vv]});
        set(V.tip, {cx: a[U] + L * a[3 + U], cy: a[Vv] + L * a[3 + Vv]});
      }
    }
    const px = P.margin + (Math.max(i, 0) - P.x0) / (P.x1 - P.x0) * (P.width - 2 * P.margin);
    for (const c of cursors) set(c, {x1: px, x2: px});
    const r = i > 0 ? D.reward[i - 1] : 0, m = i > 0 ? D.max_constraint[i - 1] : NaN;
    status.textContent = 'step ' + String(i).padStart(3) + ' / ' + T + '   t = ' + (i * D.dt).toFixed(2) + ' s   reward ' +
        (i > 0 ? r.toFixed(3) : '   -  ') + '   max constraint ' + (i > 0 ? m.toFixed(4) : '-') + (hit ? '   COLLISION' : ev === 2 ? '   JOINT LIMIT' : '');
  }
  slider.max = T;
  slider.addEventListener('input', () => draw(+slider.value));
  let timer = null;
  const play = document.getElementById('play');
  const toggle = () => {
    if (timer) { clearInterval(timer); timer = null; play.textContent = 'play'; return; }
    if (+slider.value >= T) slider.value = 0;
    play.textContent = 'pause';
    timer = setInterval(() => {
      if (+slider.value >= T) { clearInterval(timer); timer = null; play.textContent = 'play'; return; }
      slider.value = +slider.value + 1;
      draw(+slider.value);
    }, 1000 * D.dt);
  };
  play.addEventListener('click', toggle);
  // ?step=N opens at step N; ?play=0 opens paused (the page plays on open otherwise).
  const query = new URLSearchParams(location.search), start = query.get('step');
  slider.value = start === null ? 0 : Math.min(T, Math.max(0, +start));
  draw(+slider.value);
  if (query.get('play') !== '0' && T > 0) toggle();
})();
)JS";


}  // namespace

std::string render_page_html(const std::string& title, const std::string& data_json, const std::string& constraint_svg,
                             const std::string& reward_svg) {
  // "</" cannot appear inside the script element holding the data.
  std::string data;
  data.reserve(data_json.size());
  for (size_t i = 0; i < data_json.size(); ++i) {
    if (data_json[i] == '<') data += "\\u003c";
    else data += data_json[i];
  }
  std::string h;
  h += "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n<title>atacom render: " + svg_escape(title) +
       "</title>\n<style>" + kStyle + "</style>\n</head>\n<body>\n";
  h += "<h1>" + svg_escape(title) + "</h1>\n";
  h += "<div class=\"views\" id=\"views\"></div>\n";
  h += "<div class=\"controls\"><button id=\"play\">play</button><input type=\"range\" id=\"slider\" min=\"0\" max=\"0\" "
       "value=\"0\" step=\"1\"><span id=\"status\"></span></div>\n";
  h += "<div class=\"legend\" id=\"legend\"></div>\n";
  h += "<div class=\"plot\">" + constraint_svg + "</div>\n<div class=\"plot\">" + reward_svg + "</div>\n";
  h += "<script id=\"atacom-data\" type=\"application/json\">" + data + "</script>\n";
  h += "<script>" + std::string(kScript) + "</script>\n</body>\n</html>\n";
  return h;
}

}  // namespace atacom
