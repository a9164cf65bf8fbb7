// Charts drawn as inline SVG, shared by the job, compare and experiment pages (no library, no CDN):
// `chart(spec)` draws lines, dots and bands on one or two y axes; `smooth` is the trailing mean of the
// learning-curve PNG; `loadSeries` reads a job's thinned series (GET /jobs/{id}/series) as arrays.
"use strict";

(function () {
  const SVG = "http://www.w3.org/2000/svg";
  const MAX_POINTS = 1200; // per drawn series; longer ones are averaged into this many buckets
  const COLOURS = 10; // series classes c0 … c9 (dashboard.css)
  const OVERESTIMATION = ["charts/start_value", "charts/discounted_return", "eval/start_value",
    "eval/discounted_return"];

  function num(value) {
    return typeof value === "number" && isFinite(value) ? value : null;
  }

  function smooth(values, window) {
    // trailing mean over the last `window` finite values (as core.dual.diagnostics_panel)
    const out = new Array(values.length);
    const queue = [];
    let sum = 0;
    for (let i = 0; i < values.length; i++) {
      const v = values[i];
      if (v !== null) {
        queue.push(v);
        sum += v;
        if (queue.length > window) sum -= queue.shift();
      }
      out[i] = queue.length ? sum / queue.length : null;
    }
    return out;
  }

  function decimate(xs, ys) {
    const n = xs.length;
    if (n <= MAX_POINTS) return [xs, ys];
    const bx = [], by = [];
    const size = n / MAX_POINTS;
    for (let b = 0; b < MAX_POINTS; b++) {
      const start = Math.floor(b * size), end = Math.floor((b + 1) * size);
      let sx = 0, sy = 0, k = 0;
      for (let i = start; i < end; i++) {
        if (ys[i] === null) continue;
        sx += xs[i]; sy += ys[i]; k++;
      }
      if (k) { bx.push(sx / k); by.push(sy / k); }
    }
    return [bx, by];
  }

  function tickStep(lo, hi, count) {
    // the round step (1, 2, 2.5, 5 times a power of ten) that cuts [lo, hi] into at most about `count` parts
    if (!(hi > lo)) { hi = lo + 1; }
    const raw = (hi - lo) / Math.max(1, count);
    const power = Math.pow(10, Math.floor(Math.log10(raw)));
    return [1, 2, 2.5, 5, 10].map(function (m) { return m * power; }).find(function (s) { return s >= raw; });
  }

  function niceTicks(lo, hi, count) {
    if (!(hi > lo)) { hi = lo + 1; }
    const step = tickStep(lo, hi, count);
    const ticks = [];
    for (let t = Math.ceil(lo / step) * step; t <= hi + step * 1e-9; t += step) ticks.push(+t.toPrecision(12));
    return ticks;
  }

  function niceRange(range, count) {
    // widen [lo, hi] to the multiples of the tick step around it, so the axis starts and ends on a labelled
    // value. The step comes from the range itself, never from the ticks inside it: a range with one tick
    // inside (52 … 947 with a step of 500) widens to 0 … 1000, not to that tick ± 1.
    const step = tickStep(range[0], range[1], count);
    const lo = Math.floor(range[0] / step + 1e-9) * step;
    const hi = Math.ceil(range[1] / step - 1e-9) * step;
    return [+lo.toPrecision(12), +(hi > lo ? hi : lo + step).toPrecision(12)];
  }

  function fmt(value) {
    const a = Math.abs(value);
    if (a >= 1e6) return (value / 1e6).toPrecision(3).replace(/\.?0+$/, "") + "M";
    if (a >= 1e4) return (value / 1e3).toPrecision(3).replace(/\.?0+$/, "") + "k";
    if (a === 0) return "0";
    return a >= 100 ? String(Math.round(value)) : String(+value.toPrecision(3));
  }

  function el(name, attrs, text) {
    const node = document.createElementNS(SVG, name);
    Object.keys(attrs || {}).forEach(function (k) { node.setAttribute(k, attrs[k]); });
    if (text !== undefined) node.textContent = text;
    return node;
  }

  function extent(arrays, fallback) {
    let lo = Infinity, hi = -Infinity;
    arrays.forEach(function (values) {
      values.forEach(function (v) { if (v !== null) { if (v < lo) lo = v; if (v > hi) hi = v; } });
    });
    if (lo === Infinity) return fallback;
    if (lo === hi) { lo -= Math.abs(lo) * 0.1 || 0.5; hi += Math.abs(hi) * 0.1 || 0.5; }
    return [lo, hi];
  }

  function colour(index) {
    return "c" + (index % COLOURS);
  }

  // spec: {width, height, title, xLabel, left: {label, range?}, right: {label, range?} | null, series: [...]}
  // series: {name, xs, ys, cls, axis: "left"|"right", dots: bool, band: {lo: [...], hi: [...]} | undefined}
  function chart(spec) {
    const m = { top: 26, right: spec.right ? 46 : 14, bottom: 34, left: 52 };
    const w = spec.width, h = spec.height;
    const iw = w - m.left - m.right, ih = h - m.top - m.bottom;
    const svg = el("svg", { width: w, height: h, viewBox: "0 0 " + w + " " + h, class: "plot", role: "img" });
    svg.appendChild(el("title", {}, spec.title || ""));
    const xr = extent(spec.series.map(function (s) { return s.xs; }), [0, 1]);
    const sx = function (v) { return m.left + ((v - xr[0]) / (xr[1] - xr[0])) * iw; };
    const scales = {};
    ["left", "right"].forEach(function (side) {
      if (!spec[side]) return;
      const mine = spec.series.filter(function (s) { return s.axis === side; });
      const values = [];
      mine.forEach(function (s) { values.push(s.ys); if (s.band) values.push(s.band.lo, s.band.hi); });
      const r = spec[side].range || niceRange(extent(values, [0, 1]), Math.max(2, Math.floor(ih / 40)));
      scales[side] = { r: r, f: function (v) { return m.top + ih - ((v - r[0]) / (r[1] - r[0])) * ih; } };
    });
    // what a reader of the drawing needs to turn its coordinates back into values (the browser tests do):
    // the plot frame and each axis's range; each series' path and dots carry their metric key (data-key)
    svg.dataset.frame = [m.left, m.top, iw, ih].join(" ");
    svg.dataset.x = xr.join(" ");
    ["left", "right"].forEach(function (side) { if (scales[side]) svg.dataset[side] = scales[side].r.join(" "); });
    const grid = el("g", { class: "grid" });
    niceTicks(xr[0], xr[1], Math.max(2, Math.floor(iw / 90))).forEach(function (t) {
      if (t < xr[0] || t > xr[1]) return;
      grid.appendChild(el("line", { x1: sx(t), x2: sx(t), y1: m.top, y2: m.top + ih }));
      grid.appendChild(el("text", { x: sx(t), y: m.top + ih + 14, class: "tick x" }, fmt(t)));
    });
    ["left", "right"].forEach(function (side) {
      const s = scales[side];
      if (!s) return;
      niceTicks(s.r[0], s.r[1], Math.max(2, Math.floor(ih / 40))).forEach(function (t) {
        if (t < s.r[0] - 1e-12 || t > s.r[1] + 1e-12) return;
        if (side === "left") grid.appendChild(el("line", { x1: m.left, x2: m.left + iw, y1: s.f(t), y2: s.f(t) }));
        const x = side === "left" ? m.left - 6 : m.left + iw + 6;
        grid.appendChild(el("text", { x: x, y: s.f(t) + 4, class: "tick " + side }, fmt(t)));
      });
      const lx = side === "left" ? 12 : w - 8;
      grid.appendChild(el("text", { x: lx, y: m.top + ih / 2, class: "axis-label " + side,
        transform: "rotate(-90 " + lx + " " + (m.top + ih / 2) + ")" }, spec[side].label));
    });
    grid.appendChild(el("text", { x: m.left + iw / 2, y: h - 4, class: "axis-label x" }, spec.xLabel));
    grid.appendChild(el("rect", { x: m.left, y: m.top, width: iw, height: ih, class: "frame" }));
    svg.appendChild(grid);
    const legend = el("g", { class: "legend" });
    let lx = m.left, ly = 8;
    spec.series.forEach(function (s) {
      const f = scales[s.axis].f;
      if (s.band) svg.appendChild(bandPath(s, sx, f));
      const pair = decimate(s.xs, s.ys);
      let d = "";
      let pen = false;
      for (let i = 0; i < pair[0].length; i++) {
        const y = pair[1][i];
        if (y === null) { pen = false; continue; }
        d += (pen ? "L" : "M") + sx(pair[0][i]).toFixed(1) + " " + f(y).toFixed(1);
        pen = true;
      }
      const path = el("path", { d: d, class: "line " + s.cls });
      path.dataset.axis = s.axis;
      if (s.key !== undefined) path.dataset.key = String(s.key);
      if (d) svg.appendChild(path);
      if (s.dots) {
        const dots = el("g", { class: "dots " + s.cls });
        if (s.key !== undefined) dots.dataset.key = String(s.key);
        dots.dataset.axis = s.axis;
        for (let i = 0; i < pair[0].length && i < 400; i++) {
          if (pair[1][i] === null) continue;
          dots.appendChild(el("circle", { cx: sx(pair[0][i]).toFixed(1), cy: f(pair[1][i]).toFixed(1), r: 2.5 }));
        }
        svg.appendChild(dots);
      }
      if (s.name) {
        const width = 24 + 6.2 * s.name.length;
        if (lx + width > w - m.right && lx > m.left) { lx = m.left; ly -= 12; }
        legend.appendChild(el("rect", { x: lx, y: ly, width: 14, height: 4, class: "swatch " + s.cls }));
        legend.appendChild(el("text", { x: lx + 18, y: ly + 6, class: "legend-text" }, s.name));
        lx += width;
      }
    });
    if (ly < 8) legend.setAttribute("transform", "translate(0 " + (8 - ly) / 2 + ")");
    svg.appendChild(legend);
    return svg;
  }

  function bandPath(s, sx, f) {
    // the area between band.lo and band.hi, as one closed path per run of finite values
    let d = "";
    let run = [];
    function flush() {
      if (run.length > 1) {
        d += "M" + run.map(function (i) { return sx(s.xs[i]).toFixed(1) + " " + f(s.band.hi[i]).toFixed(1); }).join("L");
        d += "L" + run.slice().reverse().map(function (i) {
          return sx(s.xs[i]).toFixed(1) + " " + f(s.band.lo[i]).toFixed(1);
        }).join("L") + "Z";
      }
      run = [];
    }
    for (let i = 0; i < s.xs.length; i++) {
      if (s.band.lo[i] === null || s.band.hi[i] === null) flush();
      else run.push(i);
    }
    flush();
    const path = el("path", { d: d, class: "band " + s.cls });
    if (s.key !== undefined) path.dataset.key = String(s.key);
    return path;
  }

  // A job's records as columns: episode, x (env steps when every record has one, else episode), return,
  // training success, greedy evaluations, and the `dual/…` diagnostics.
  function columns() {
    return { episode: [], x: [], ret: [], success: [], evalX: [], evalY: [], evalEpisode: [], dual: {}, stepAxis: true };
  }

  function addRecord(rec, metric) {
    const d = metric.data || {};
    const last = rec.episode.length ? rec.episode[rec.episode.length - 1] : 0;
    if (metric.episode <= last) truncateFrom(rec, metric.episode);
    const step = num(metric.global_step);
    if (step === null) rec.stepAxis = false;
    const x = rec.stepAxis && step !== null ? step : metric.episode;
    rec.episode.push(metric.episode);
    rec.x.push(x);
    rec.ret.push(num(d["charts/episodic_return"]));
    rec.success.push(num(d["charts/success"]));
    const evalSuccess = num(d["eval/success_rate"]);
    if (evalSuccess !== null) {
      rec.evalX.push(x);
      rec.evalY.push(evalSuccess);
      rec.evalEpisode.push(metric.episode);
    }
    const n = rec.episode.length;
    Object.keys(d).forEach(function (key) {
      // the dual-system diagnostics and the overestimation pairs (the critic's start value, the return
      // earned), of the training episodes and of the greedy evaluations (eval/…: only on evaluation records)
      const diagnostic = key.indexOf("dual/") === 0 || OVERESTIMATION.indexOf(key) >= 0;
      if (diagnostic && !rec.dual[key]) rec.dual[key] = [];
    });
    Object.keys(rec.dual).forEach(function (key) {
      const column = rec.dual[key];
      while (column.length < n - 1) column.push(null);
      column.push(num(d[key]));
    });
  }

  function truncateFrom(rec, episode) {
    // a resumed attempt rewrites episodes at or after its checkpoint: drop what it replaces
    let keep = rec.episode.length;
    while (keep > 0 && rec.episode[keep - 1] >= episode) keep--;
    if (keep === rec.episode.length) return;
    ["episode", "x", "ret", "success"].forEach(function (k) { rec[k].length = keep; });
    Object.keys(rec.dual).forEach(function (k) { rec.dual[k].length = keep; });
    let evalKeep = rec.evalEpisode.length;
    while (evalKeep > 0 && rec.evalEpisode[evalKeep - 1] >= episode) evalKeep--;
    rec.evalX.length = rec.evalY.length = rec.evalEpisode.length = evalKeep;
  }

  // Reads GET /jobs/{id}/series (every k-th episode, the first and the last, every greedy evaluation);
  // resolves to {rec, episodes, stride} or {error}.
  async function loadSeries(jobId, points) {
    const result = await window.dualsys.api("GET", "/jobs/" + jobId + "/series?points=" + (points || 1000));
    if (!result.ok || !result.body) return { error: result.message };
    const rec = columns();
    result.body.data.forEach(function (metric) { addRecord(rec, metric); });
    return { rec: rec, episodes: result.body.episodes, stride: result.body.stride };
  }

  // Linear interpolation of (xs, ys) at `grid` (null outside [xs[0], xs[last]] or where ys is null).
  function interpolate(xs, ys, grid) {
    const out = new Array(grid.length).fill(null);
    let j = 0;
    for (let g = 0; g < grid.length; g++) {
      const x = grid[g];
      while (j < xs.length - 1 && xs[j + 1] < x) j++;
      if (!xs.length || x < xs[0] || x > xs[xs.length - 1]) continue;
      const k = Math.min(j + 1, xs.length - 1);
      const a = ys[j], b = ys[k];
      if (a === null || b === null) continue;
      out[g] = xs[k] === xs[j] ? a : a + (b - a) * (x - xs[j]) / (xs[k] - xs[j]);
    }
    return out;
  }

  window.dualsys.charts = {
    chart: chart, smooth: smooth, fmt: fmt, num: num, colour: colour, columns: columns, addRecord: addRecord,
    loadSeries: loadSeries, interpolate: interpolate, niceRange: niceRange,
  };
})();
