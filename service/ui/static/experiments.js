// Experiments pages, from the REST API's JSON (GET /experiments, GET /experiments/{id}): the list, and
// one experiment's grid of cells (method × reward × seed, each a train job; tick cells to compare them),
// each method's learning curve (mean ± 1 s.d. over seeds, from the cells' thinned series), its report's
// table and a figure of each method's IQM with its 95% CI. Values go into the page with textContent only.
"use strict";

(function () {
  const data = window.dualsys.pageData();
  const SVG = "http://www.w3.org/2000/svg";
  const POLL_MS = 2000;
  const FINISHED = ["succeeded", "failed", "cancelled"];
  const METRICS = [
    ["auc", "AuC"], ["auc_from_minus1", "AuC (from −1)"], ["final_perf", "Final Perf"],
    ["train_success", "Training success"], ["success", "Greedy success"],
  ];

  function node(tag, text, cls) {
    const el = document.createElement(tag);
    if (text !== undefined && text !== null) el.textContent = String(text);
    if (cls) el.className = cls;
    return el;
  }

  function link(href, text) {
    const a = node("a", text);
    a.href = href;
    return a;
  }

  function fmt(value) {
    if (value === null || value === undefined || !isFinite(value)) return "—";
    return Math.abs(value) >= 100 ? value.toFixed(0) : value.toPrecision(3);
  }

  function status(text) {
    return node("span", text, "status s-" + text);
  }

  // ------------------------------------------------------------------ the list
  async function showList() {
    const body = document.getElementById("experiments-body");
    const result = await window.dualsys.api("GET", "/experiments?limit=100");
    if (!result.ok) {
      body.replaceChildren(row([node("td", result.message, "empty")], 5));
      return;
    }
    const rows = result.body.data.map(function (e) {
      const tr = document.createElement("tr");
      tr.dataset.experimentId = String(e.id);
      const id = node("td", null, "num");
      id.appendChild(link("/ui/experiments/" + e.id, String(e.id)));
      const name = node("td");
      name.appendChild(link("/ui/experiments/" + e.id, e.name));
      tr.append(id, name, node("td", e.workers, "num"), node("td", e.cancel_requested ? "cancel requested" : ""),
        node("td", e.created_at.replace("T", " ").slice(0, 19) + " UTC"));
      return tr;
    });
    if (!rows.length) {
      const td = node("td", "No experiments yet. Submit one with POST /experiments (an experiment file).", "empty");
      td.colSpan = 5;
      rows.push(row([td]));
    }
    body.replaceChildren.apply(body, rows);
    document.getElementById("experiments-count").textContent = result.body.count + " experiments";
  }

  function row(cells) {
    const tr = document.createElement("tr");
    tr.append.apply(tr, cells);
    return tr;
  }

  // ------------------------------------------------------------------ one experiment
  function parseCell(cell) {
    // "label/reward/seed-s"
    const parts = cell.split("/");
    const seed = (parts[2] || "").replace(/^seed-/, "");
    return { label: parts[0] || cell, reward: parts[1] || "", seed: seed };
  }

  function drawGrid(experiment) {
    const host = document.getElementById("grid");
    const cells = experiment.jobs.map(function (j) { return Object.assign(parseCell(j.cell), { job: j }); });
    const labels = [], rewards = [], seeds = [];
    cells.forEach(function (c) {
      if (labels.indexOf(c.label) < 0) labels.push(c.label);
      if (rewards.indexOf(c.reward) < 0) rewards.push(c.reward);
      if (seeds.indexOf(c.seed) < 0) seeds.push(c.seed);
    });
    const table = node("table", null, "grid");
    const head1 = row([node("th", "method")]);
    rewards.forEach(function (r) {
      const th = node("th", r + " reward", "group");
      th.colSpan = seeds.length;
      head1.appendChild(th);
    });
    const head2 = row([node("th", "")]);
    rewards.forEach(function () {
      seeds.forEach(function (s) { head2.appendChild(node("th", "seed " + s, "seed")); });
    });
    const thead = document.createElement("thead");
    thead.append(head1, head2);
    const tbody = document.createElement("tbody");
    labels.forEach(function (label) {
      const tr = row([node("th", label, "method")]);
      rewards.forEach(function (reward) {
        seeds.forEach(function (seed) {
          const c = cells.find(function (x) { return x.label === label && x.reward === reward && x.seed === seed; });
          const td = node("td", null, "cell");
          if (c) {
            td.dataset.status = c.job.status;
            td.dataset.jobId = String(c.job.job_id);
            const box = document.createElement("input");
            box.type = "checkbox";
            box.className = "pick";
            box.value = String(c.job.job_id);
            box.checked = chosen.indexOf(box.value) >= 0;
            box.setAttribute("aria-label", "choose " + c.job.cell);
            td.appendChild(box);
            const a = link("/ui/jobs/" + c.job.job_id, "");
            a.appendChild(status(c.job.status));
            a.appendChild(node("small", " ep " + c.job.episode, "muted"));
            if (c.job.reason) a.title = c.job.reason;
            td.appendChild(a);
          } else {
            td.textContent = "—";
          }
          tr.appendChild(td);
        });
      });
      tbody.appendChild(tr);
    });
    table.append(thead, tbody);
    host.replaceChildren(table);
  }

  // ------------------------------------------------------------------ cells chosen for the compare page
  const chosen = [];

  function showChosen() {
    const button = document.getElementById("compare-cells");
    if (!button) return;
    button.disabled = chosen.length === 0;
    button.textContent = chosen.length ? "Compare " + chosen.length + " chosen cell" + (chosen.length > 1 ? "s" : "")
      : "Compare chosen cells";
  }

  // ------------------------------------------------------------------ per-method curves
  const CURVE_POINTS = 200; // records per cell's thinned series
  const GRID = 120; // env-step positions a method's mean and band are computed at
  const CURVES_EVERY_MS = 30000;

  function methodCurves(experiment, loaded) {
    // per reward: per method, the mean and s.d. over its seeds of each cell's smoothed return, interpolated
    // on a common env-step grid up to the step every seed of the method has reached
    const charts = window.dualsys.charts;
    const out = {};
    experiment.jobs.forEach(function (job) {
      const series = loaded[job.job_id];
      if (!series || series.rec.episode.length < 2) return;
      const cell = parseCell(job.cell);
      const perReward = out[cell.reward] = out[cell.reward] || {};
      (perReward[cell.label] = perReward[cell.label] || []).push(series.rec);
    });
    const result = {};
    Object.keys(out).forEach(function (reward) {
      result[reward] = Object.keys(out[reward]).map(function (label) {
        const runs = out[reward][label];
        const start = Math.max.apply(null, runs.map(function (r) { return r.x[0]; }));
        const end = Math.min.apply(null, runs.map(function (r) { return r.x[r.x.length - 1]; }));
        const grid = [];
        if (end > start) for (let i = 0; i < GRID; i++) grid.push(start + (end - start) * i / (GRID - 1));
        const curves = runs.map(function (r) {
          const win = Math.max(1, Math.min(100, Math.round(r.episode.length / 25)));
          return charts.interpolate(r.x, charts.smooth(r.ret, win), grid);
        });
        const mean = [], lo = [], hi = [];
        grid.forEach(function (_, g) {
          const values = curves.map(function (c) { return c[g]; }).filter(function (v) { return v !== null; });
          if (!values.length) { mean.push(null); lo.push(null); hi.push(null); return; }
          const m = values.reduce(function (a, b) { return a + b; }, 0) / values.length;
          const sd = Math.sqrt(values.reduce(function (a, b) { return a + (b - m) * (b - m); }, 0) / values.length);
          mean.push(m); lo.push(m - sd); hi.push(m + sd);
        });
        return { label: label, seeds: runs.length, grid: grid, mean: mean, lo: lo, hi: hi };
      });
    });
    return result;
  }

  function drawCurves(experiment, loaded) {
    const charts = window.dualsys.charts;
    const host = document.getElementById("curves");
    const perReward = methodCurves(experiment, loaded);
    const rewards = Object.keys(perReward);
    if (!rewards.length) {
      host.replaceChildren(node("p", "The curves appear once cells have recorded episodes.", "muted"));
      return;
    }
    const labels = [];
    experiment.jobs.forEach(function (j) {
      const label = parseCell(j.cell).label;
      if (labels.indexOf(label) < 0) labels.push(label);
    });
    const width = Math.max(360, host.clientWidth || 900);
    const figures = rewards.map(function (reward) {
      const series = perReward[reward].filter(function (m) { return m.grid.length; }).map(function (m) {
        const cls = charts.colour(labels.indexOf(m.label));
        return { name: m.label + " (" + m.seeds + " seed" + (m.seeds > 1 ? "s" : "") + ")", key: m.label,
          xs: m.grid, ys: m.mean, band: { lo: m.lo, hi: m.hi }, cls: cls, axis: "left" };
      });
      const figure = node("figure", null, "chart");
      figure.dataset.reward = reward;
      figure.dataset.methods = String(series.length);
      figure.appendChild(series.length ? charts.chart({ width: width, height: 280, title: reward + " reward",
        xLabel: "env steps", left: { label: "episodic return" }, right: null, series: series })
        : node("p", "not enough recorded episodes yet", "muted"));
      const caption = node("figcaption", reward + " reward");
      figure.appendChild(caption);
      return figure;
    });
    host.replaceChildren.apply(host, figures);
  }

  async function loadCurves(experiment) {
    const charts = window.dualsys.charts;
    const started = experiment.jobs.filter(function (j) { return j.episode > 0; });
    const results = await Promise.all(started.map(function (j) { return charts.loadSeries(j.job_id, CURVE_POINTS); }));
    const loaded = {};
    results.forEach(function (result, i) { if (!result.error) loaded[started[i].job_id] = result; });
    drawCurves(experiment, loaded);
  }

  function drawHead(experiment) {
    const s = document.getElementById("experiment-status");
    s.replaceChildren(status(experiment.status));
    const c = experiment.cells;
    document.getElementById("experiment-cells").textContent =
      c.done + " of " + c.total + " cells done · " + c.running + " running · " + c.queued + " queued · " +
      c.failed + " failed · " + c.cancelled + " cancelled";
    document.getElementById("experiment-spec").textContent = JSON.stringify(experiment.spec, null, 2);
    document.getElementById("cancel-box").hidden = FINISHED.indexOf(experiment.status) >= 0;
  }

  function drawReport(report, pending) {
    const host = document.getElementById("report");
    if (!report) {
      host.replaceChildren(node("p", pending ? "computing the report of the finished cells…"
        : "The report appears once a cell has finished.", "muted"));
      return;
    }
    const parts = [node("p", report.done + " of " + report.cells + " cells in the report" +
      (report.missing && report.missing.length ? " (missing: " + report.missing.length + ")" : "") + "." +
      (pending ? " A report with more finished cells is being computed." : ""), "muted")];
    (report.rewards || []).forEach(function (reward) {
      parts.push(node("h3", reward + " reward"));
      const table = node("table", null, "report");
      const head = row([node("th", "method"), node("th", "seeds", "num")]);
      METRICS.forEach(function (m) { head.appendChild(node("th", m[1] + " IQM [95% CI]", "num")); });
      head.appendChild(node("th", "P(better than baseline), AuC", "num"));
      const thead = document.createElement("thead");
      thead.appendChild(head);
      const tbody = document.createElement("tbody");
      Object.keys(report.methods || {}).forEach(function (label) {
        const entry = (report.methods[label] || {})[reward];
        if (!entry) return;
        const tr = row([node("th", label, "method"), node("td", entry.seeds, "num")]);
        METRICS.forEach(function (m) {
          const s = entry[m[0]] || {};
          const ci = s.ci || [null, null];
          tr.appendChild(node("td", fmt(s.iqm) + " [" + fmt(ci[0]) + ", " + fmt(ci[1]) + "]", "num"));
        });
        const p = entry.prob_improvement && entry.prob_improvement.auc;
        tr.appendChild(node("td", p ? fmt(p.p) + " vs " + entry.baseline : "—", "num"));
        tbody.appendChild(tr);
      });
      table.append(thead, tbody);
      parts.push(table);
      parts.push(scoresFigure(report, reward));
    });
    host.replaceChildren.apply(host, parts);
  }

  function el(name, attrs, text) {
    const n = document.createElementNS(SVG, name);
    Object.keys(attrs).forEach(function (k) { n.setAttribute(k, attrs[k]); });
    if (text !== undefined) n.textContent = text;
    return n;
  }

  // One row per method: its IQM (dot) and 95% CI (bar) for greedy success and for AuC (from −1), both on
  // [0, 1] (the paper's Fig. 10/11 scores).
  function scoresFigure(report, reward) {
    const labels = Object.keys(report.methods || {}).filter(function (l) { return report.methods[l][reward]; });
    const panels = [["success", "greedy success"], ["auc_from_minus1", "AuC (from −1)"]];
    const left = 130, panelW = 260, gap = 30, rowH = 22, top = 24;
    const w = left + panels.length * (panelW + gap), h = top + labels.length * rowH + 26;
    const svg = el("svg", { width: w, height: h, viewBox: "0 0 " + w + " " + h, class: "plot scores", role: "img" });
    svg.appendChild(el("title", {}, reward + " reward: IQM and 95% CI per method"));
    panels.forEach(function (panel, p) {
      const x0 = left + p * (panelW + gap);
      const sx = function (v) { return x0 + Math.max(0, Math.min(1, v)) * panelW; };
      svg.appendChild(el("text", { x: x0 + panelW / 2, y: 14, class: "axis-label x" }, panel[1]));
      [0, 0.25, 0.5, 0.75, 1].forEach(function (t) {
        svg.appendChild(el("line", { x1: sx(t), x2: sx(t), y1: top, y2: h - 22, class: "gridline" }));
        svg.appendChild(el("text", { x: sx(t), y: h - 8, class: "tick x" }, String(t)));
      });
      labels.forEach(function (label, i) {
        const s = report.methods[label][reward][panel[0]] || {};
        const y = top + i * rowH + rowH / 2;
        if (p === 0) svg.appendChild(el("text", { x: left - 8, y: y + 4, class: "tick left" }, label));
        if (s.ci && s.ci[0] !== null && s.ci[1] !== null) {
          svg.appendChild(el("line", { x1: sx(s.ci[0]), x2: sx(s.ci[1]), y1: y, y2: y, class: "ci" }));
        }
        if (s.iqm !== null && s.iqm !== undefined) {
          svg.appendChild(el("circle", { cx: sx(s.iqm), cy: y, r: 4, class: "iqm" }));
        }
      });
    });
    const figure = node("figure", null, "chart");
    figure.appendChild(svg);
    return figure;
  }

  async function showExperiment() {
    const id = data.experiment_id;
    let doneBefore = -1;
    let pending = false;
    let timer = null;
    let curvesAt = 0;
    let curvesDone = -1;
    let busy = false;
    // One refresh at a time: on a loaded machine a report request can outlast the poll period, and an older
    // answer arriving after a newer one would redraw a stale report (and re-flag it pending after the poll
    // had stopped), leaving the page on it.
    async function refresh() {
      if (busy) return;
      busy = true;
      try {
        await refreshOnce();
      } finally {
        busy = false;
      }
    }
    async function refreshOnce() {
      const result = await window.dualsys.api("GET", "/experiments/" + id + "?report=false");
      if (!result.ok) {
        document.getElementById("experiment-cells").textContent = result.message;
        return;
      }
      const experiment = result.body;
      drawHead(experiment);
      drawGrid(experiment);
      // the curves: at first, when a cell finishes, and every 30 s while cells run
      if (experiment.cells.done !== curvesDone || (experiment.cells.running && Date.now() - curvesAt > CURVES_EVERY_MS)) {
        curvesDone = experiment.cells.done;
        curvesAt = Date.now();
        loadCurves(experiment);
      }
      if (experiment.cells.done !== doneBefore || pending) {
        doneBefore = experiment.cells.done;
        // the service bootstraps the report in the background once per set of finished cells and answers
        // the latest finished one with report_pending: ask again until it is current
        const full = await window.dualsys.api("GET", "/experiments/" + id);
        if (full.ok) {
          pending = !!full.body.report_pending;
          drawReport(full.body.report, pending);
        } else {
          pending = false;
          document.getElementById("report").replaceChildren(
            node("p", "report unavailable: " + full.message, "result refused"));
        }
      }
      const finished = FINISHED.indexOf(experiment.status) >= 0 && !pending;
      if (!finished && timer === null) {
        timer = window.setInterval(function () { if (!document.hidden) refresh(); }, POLL_MS);
      } else if (finished && timer !== null) {
        window.clearInterval(timer);
        timer = null;
      }
    }
    document.getElementById("grid").addEventListener("change", function (event) {
      const box = event.target;
      if (!box.classList || !box.classList.contains("pick")) return;
      const at = chosen.indexOf(box.value);
      if (box.checked && at < 0) chosen.push(box.value);
      if (!box.checked && at >= 0) chosen.splice(at, 1);
      showChosen();
    });
    document.getElementById("compare-cells").addEventListener("click", function () {
      if (chosen.length) window.location.href = "/ui/compare?jobs=" + chosen.join(",");
    });
    document.getElementById("cancel-button").addEventListener("click", async function () {
      const out = document.getElementById("cancel-result");
      out.textContent = "…";
      const result = await window.dualsys.api("POST", "/experiments/" + id + "/cancel");
      window.dualsys.showResult(out, result, "cancel requested: unfinished cells stop");
      if (result.ok) refresh();
    });
    await refresh();
  }

  if (data.experiment_id) showExperiment();
  else if (document.getElementById("experiments-body")) {
    showList();
    document.addEventListener("dualsys:experiment-submitted", showList);
  }
})();
