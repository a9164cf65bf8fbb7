// Job page: the learning curve (episodic return and greedy success against env steps) and the
// dual-system diagnostics, drawn as inline SVG from GET /jobs/{id}/metrics, then extended from the
// job's server-sent events (GET /jobs/{id}/events) while it runs. Cancel is a REST call with the
// tab's bearer token.
"use strict";

(function () {
  const SVG = "http://www.w3.org/2000/svg";
  const MAX_POINTS = 1200; // per drawn series; longer histories are averaged into this many buckets
  const REDRAW_MS = 500;
  const PAGE = 5000;
  const data = window.dualsys.pageData();
  const jobId = data.job_id;
  const groups = data.diagnostics || [];
  const curve = document.getElementById("curve");
  const panels = document.getElementById("diagnostics");
  const counter = document.getElementById("curve-count");

  // ------------------------------------------------------------------ the records received
  const rec = { episode: [], x: [], ret: [], success: [], evalX: [], evalY: [], evalEpisode: [], dual: {} };
  let stepAxis = true;

  function num(value) {
    return typeof value === "number" && isFinite(value) ? value : null;
  }

  function truncateFrom(episode) {
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

  function add(metric) {
    const d = metric.data || {};
    const last = rec.episode.length ? rec.episode[rec.episode.length - 1] : 0;
    if (metric.episode <= last) truncateFrom(metric.episode);
    const step = num(metric.global_step);
    if (step === null) stepAxis = false;
    const x = stepAxis && step !== null ? step : metric.episode;
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
      if (key.indexOf("dual/") !== 0) return;
      if (!rec.dual[key]) rec.dual[key] = [];
    });
    Object.keys(rec.dual).forEach(function (key) {
      const column = rec.dual[key];
      while (column.length < n - 1) column.push(null);
      column.push(num(d[key]));
    });
  }

  // ------------------------------------------------------------------ numbers → pictures
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

  function niceTicks(lo, hi, count) {
    if (!(hi > lo)) { hi = lo + 1; }
    const raw = (hi - lo) / Math.max(1, count);
    const power = Math.pow(10, Math.floor(Math.log10(raw)));
    const step = [1, 2, 2.5, 5, 10].map(function (m) { return m * power; }).find(function (s) { return s >= raw; });
    const ticks = [];
    for (let t = Math.ceil(lo / step) * step; t <= hi + step * 1e-9; t += step) ticks.push(+t.toPrecision(12));
    return ticks;
  }

  function niceRange(range, count) {
    // widen [lo, hi] to the tick steps around it, so the axis starts and ends on a labelled value
    const ticks = niceTicks(range[0], range[1], count);
    const step = ticks.length > 1 ? ticks[1] - ticks[0] : 1;
    const lo = ticks[0] > range[0] ? ticks[0] - step : ticks[0];
    const hi = ticks[ticks.length - 1] < range[1] ? ticks[ticks.length - 1] + step : ticks[ticks.length - 1];
    return [+lo.toPrecision(12), +hi.toPrecision(12)];
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

  // spec: {width, height, xLabel, left: {label, range}, right: {label, range} | null, series: [...]}
  // series: {name, xs, ys, cls, axis: "left"|"right", dots: bool}
  function chart(spec) {
    const m = { top: 26, right: spec.right ? 46 : 14, bottom: 34, left: 52 };
    const w = spec.width, h = spec.height;
    const iw = w - m.left - m.right, ih = h - m.top - m.bottom;
    const svg = el("svg", { width: w, height: h, viewBox: "0 0 " + w + " " + h, class: "plot", role: "img" });
    svg.appendChild(el("title", {}, spec.title || ""));
    const allX = spec.series.map(function (s) { return s.xs; });
    const xr = extent(allX, [0, 1]);
    const sx = function (v) { return m.left + ((v - xr[0]) / (xr[1] - xr[0])) * iw; };
    const scales = {};
    ["left", "right"].forEach(function (side) {
      if (!spec[side]) return;
      const r = spec[side].range || niceRange(extent(spec.series.filter(function (s) { return s.axis === side; })
        .map(function (s) { return s.ys; }), [0, 1]), Math.max(2, Math.floor(ih / 40)));
      scales[side] = { r: r, f: function (v) { return m.top + ih - ((v - r[0]) / (r[1] - r[0])) * ih; } };
    });
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
      const label = el("text", { x: lx, y: m.top + ih / 2, class: "axis-label " + side,
        transform: "rotate(-90 " + lx + " " + (m.top + ih / 2) + ")" }, spec[side].label);
      grid.appendChild(label);
    });
    grid.appendChild(el("text", { x: m.left + iw / 2, y: h - 4, class: "axis-label x" }, spec.xLabel));
    grid.appendChild(el("rect", { x: m.left, y: m.top, width: iw, height: ih, class: "frame" }));
    svg.appendChild(grid);
    const legend = el("g", { class: "legend" });
    let lx = m.left;
    spec.series.forEach(function (s) {
      const pair = decimate(s.xs, s.ys);
      const f = scales[s.axis].f;
      let d = "";
      let pen = false;
      for (let i = 0; i < pair[0].length; i++) {
        const y = pair[1][i];
        if (y === null) { pen = false; continue; }
        d += (pen ? "L" : "M") + sx(pair[0][i]).toFixed(1) + " " + f(y).toFixed(1);
        pen = true;
      }
      if (d) svg.appendChild(el("path", { d: d, class: "line " + s.cls }));
      if (s.dots) {
        const dots = el("g", { class: "dots " + s.cls });
        for (let i = 0; i < pair[0].length && i < 400; i++) {
          if (pair[1][i] === null) continue;
          dots.appendChild(el("circle", { cx: sx(pair[0][i]).toFixed(1), cy: f(pair[1][i]).toFixed(1), r: 2.5 }));
        }
        svg.appendChild(dots);
      }
      if (s.name) {
        legend.appendChild(el("rect", { x: lx, y: 8, width: 14, height: 4, class: "swatch " + s.cls }));
        const text = el("text", { x: lx + 18, y: 14, class: "legend-text" }, s.name);
        legend.appendChild(text);
        lx += 24 + 6.2 * s.name.length;
      }
    });
    svg.appendChild(legend);
    return svg;
  }

  // ------------------------------------------------------------------ drawing the page
  function windowFor(n) {
    return Math.max(1, Math.min(100, Math.round(n / 25)));
  }

  function drawCurve() {
    const n = rec.episode.length;
    curve.dataset.points = String(n);
    counter.textContent = n ? "(" + n + " episodes, " + rec.evalY.length + " greedy evaluations)" : "";
    if (!n) {
      curve.replaceChildren(Object.assign(document.createElement("p"),
        { className: "muted", textContent: data.live ? "waiting for the first episode…" : "no metrics recorded" }));
      return;
    }
    const win = windowFor(n);
    const series = win > 1 ? [
      { name: "episodic return", xs: rec.x, ys: rec.ret, cls: "raw", axis: "left" },
      { name: "return, mean of " + win, xs: rec.x, ys: smooth(rec.ret, win), cls: "ret", axis: "left" },
    ] : [{ name: "episodic return", xs: rec.x, ys: rec.ret, cls: "ret", axis: "left" }];
    if (rec.evalY.length) {
      series.push({ name: "greedy success", xs: rec.evalX, ys: rec.evalY, cls: "succ", axis: "right", dots: true });
    } else if (rec.success.some(function (v) { return v !== null; })) {
      series.push({ name: win > 1 ? "training success, mean of " + win : "training success", xs: rec.x,
        ys: smooth(rec.success, win),
        cls: "succ dashed", axis: "right" });
    }
    const width = Math.max(320, curve.clientWidth || 800);
    curve.replaceChildren(chart({
      width: width, height: 280, title: "learning curve", xLabel: stepAxis ? "env steps" : "episode",
      left: { label: "episodic return" }, right: { label: "success rate", range: [0, 1] }, series: series,
    }));
  }

  function drawDiagnostics() {
    const n = rec.episode.length;
    panels.dataset.points = String(n);
    const present = groups.filter(function (g) {
      return g.series.some(function (s) {
        return rec.dual[s[0]] && rec.dual[s[0]].some(function (v) { return v !== null; });
      });
    });
    if (!present.length) {
      panels.replaceChildren(Object.assign(document.createElement("p"), {
        className: "muted",
        textContent: n ? "This job records no dual-system diagnostics (a model-free method, or not a train job)."
          : (data.live ? "waiting for the first episode…" : "no metrics recorded"),
      }));
      return;
    }
    const win = windowFor(n);
    const columns = window.matchMedia("(max-width: 900px)").matches ? 1 : 2;
    const width = Math.max(260, Math.floor(((panels.clientWidth || 800) - 12 * (columns - 1)) / columns) - 10);
    const nodes = present.map(function (g) {
      const series = g.series.filter(function (s) { return rec.dual[s[0]]; }).map(function (s, i) {
        return { name: s[1], xs: rec.x, ys: smooth(rec.dual[s[0]], win), cls: "d" + i, axis: "left" };
      });
      const box = document.createElement("figure");
      box.className = "panel";
      box.dataset.keys = g.series.map(function (s) { return s[0]; }).join(" ");
      box.appendChild(chart({ width: width, height: 190, title: g.title, xLabel: stepAxis ? "env steps" : "episode",
        left: { label: g.unit }, right: null, series: series }));
      const caption = document.createElement("figcaption");
      caption.textContent = g.title + " (mean of " + win + " episodes)";
      box.appendChild(caption);
      return box;
    });
    panels.replaceChildren.apply(panels, nodes);
  }

  function drawSuccess() {
    const out = document.getElementById("job-success");
    if (!out || !rec.episode.length) return;
    let text = null, note = "";
    if (rec.evalY.length) {
      text = rec.evalY[rec.evalY.length - 1].toFixed(2);
      note = "greedy evaluation at episode " + rec.evalEpisode[rec.evalEpisode.length - 1];
    } else {
      const recent = rec.success.slice(-100).filter(function (v) { return v !== null; });
      if (recent.length) {
        text = (recent.reduce(function (a, b) { return a + b; }, 0) / recent.length).toFixed(2);
        note = "training episodes, last " + recent.length;
      }
    }
    if (text === null) return;
    const small = Object.assign(document.createElement("small"), { className: "muted", textContent: note });
    out.replaceChildren(document.createTextNode(text + " "), small);
  }

  let pending = null;
  function draw() {
    pending = null;
    drawCurve();
    drawDiagnostics();
    drawSuccess();
  }
  function scheduleDraw() {
    if (pending === null) pending = window.setTimeout(draw, REDRAW_MS);
  }
  let resizeTimer = null;
  window.addEventListener("resize", function () {
    window.clearTimeout(resizeTimer);
    resizeTimer = window.setTimeout(draw, 200);
  });

  // ------------------------------------------------------------------ status, artifacts, summary
  function showJob(job) {
    if (!job || !job.status) return;
    const status = document.getElementById("job-status");
    status.textContent = job.status + (job.cancel_requested && job.status === "running" ? " (cancelling)" : "");
    status.className = "status s-" + job.status;
    if (job.progress) {
      const p = job.progress;
      document.getElementById("job-progress").dataset.episode = String(p.episode);
      document.getElementById("job-progress-text").textContent =
        p.episode + (p.total ? " / " + p.total : "") + " episodes";
      const bar = document.getElementById("job-progress-bar");
      if (bar && p.total) bar.value = Math.min(p.episode, p.total);
    }
    if (job.attempt !== undefined) document.getElementById("job-attempt").textContent = String(job.attempt);
    if (job.reason !== undefined) document.getElementById("job-reason").textContent = job.reason || "—";
    if (job.finished_at) document.getElementById("job-finished").textContent = job.finished_at.replace("T", " ").slice(0, 19) + " UTC";
    const finished = ["succeeded", "failed", "cancelled"].indexOf(job.status) >= 0;
    document.getElementById("cancel-box").hidden = finished;
  }

  async function refreshArtifacts() {
    const result = await window.dualsys.api("GET", "/jobs/" + jobId + "/artifacts");
    if (!result.ok || !result.body) return;
    const list = document.getElementById("artifacts");
    const items = result.body.data.map(function (a) {
      const li = document.createElement("li");
      const link = Object.assign(document.createElement("a"), { href: a.url, textContent: a.name });
      link.setAttribute("download", "");
      const note = Object.assign(document.createElement("small"), { className: "muted",
        textContent: " " + (a.size / 1000).toFixed(1) + " kB · " + a.kind });
      li.append(link, " ", note);
      return li;
    });
    if (items.length) list.replaceChildren.apply(list, items);
  }

  // ------------------------------------------------------------------ loading and following
  async function loadHistory() {
    let since = 0;
    for (;;) {
      const result = await window.dualsys.api("GET", "/jobs/" + jobId + "/metrics?since=" + since + "&limit=" + PAGE);
      if (!result.ok || !result.body) break;
      result.body.data.forEach(add);
      if (result.body.data.length < PAGE) break;
      since = rec.episode[rec.episode.length - 1];
    }
    draw();
  }

  function follow() {
    const since = rec.episode.length ? rec.episode[rec.episode.length - 1] : 0;
    const source = new EventSource("/jobs/" + jobId + "/events?since=" + since);
    source.addEventListener("metric", function (event) {
      add(JSON.parse(event.data));
      scheduleDraw();
    });
    source.addEventListener("status", function (event) {
      showJob(JSON.parse(event.data));
    });
    source.addEventListener("end", function (event) {
      source.close();
      const job = JSON.parse(event.data);
      showJob(job);
      scheduleDraw();
      refreshArtifacts();
    });
  }

  document.getElementById("cancel-button").addEventListener("click", async function () {
    const out = document.getElementById("cancel-result");
    out.textContent = "…";
    const result = await window.dualsys.api("POST", "/jobs/" + jobId + "/cancel");
    window.dualsys.showResult(out, result, "cancel requested; the job stops within seconds");
    if (result.ok) showJob(result.body);
  });

  loadHistory().then(function () {
    if (data.live) follow();
  });
})();
