// Job page: the learning curve (episodic return and greedy success against env steps) and the
// dual-system diagnostics, drawn as inline SVG (charts.js) from the job's thinned series
// (GET /jobs/{id}/series: every k-th episode, the first and the last, every greedy evaluation; every record
// on "full resolution", from GET /jobs/{id}/metrics), then extended from the job's server-sent events
// (GET /jobs/{id}/events) while it runs. Cancel is a REST call with the tab's bearer token.
"use strict";

(function () {
  const charts = window.dualsys.charts;
  const chart = charts.chart, smooth = charts.smooth;
  const REDRAW_MS = 500;
  const PAGE = 5000;
  const POINTS = 1000; // records of the thinned series the page starts with
  const RETURN = "charts/episodic_return";
  const data = window.dualsys.pageData();
  const jobId = data.job_id;
  const groups = data.diagnostics || [];
  const curve = document.getElementById("curve");
  const panels = document.getElementById("diagnostics");
  const counter = document.getElementById("curve-count");
  const fullButton = document.getElementById("full-resolution");

  // ------------------------------------------------------------------ the records received
  let rec = charts.columns();
  let shown = { episodes: 0, stride: 1 }; // what the series held when loaded (stride 1: every record)

  function add(metric) {
    charts.addRecord(rec, metric);
    if (metric.episode > shown.episodes) shown.episodes = metric.episode;
  }

  // ------------------------------------------------------------------ drawing the page
  function windowFor(n) {
    return Math.max(1, Math.min(100, Math.round(n / 25)));
  }

  function drawCurve() {
    const n = rec.episode.length;
    curve.dataset.points = String(n);
    curve.dataset.stride = String(shown.stride);
    counter.textContent = !n ? "" : shown.stride > 1
      ? "(" + n + " of " + shown.episodes + " episodes: every " + shown.stride + "th, the first, the last and " +
        rec.evalY.length + " greedy evaluations)"
      : "(" + n + " episodes, " + rec.evalY.length + " greedy evaluations)";
    if (fullButton) fullButton.hidden = shown.stride <= 1;
    if (!n) {
      curve.replaceChildren(Object.assign(document.createElement("p"),
        { className: "muted", textContent: data.live ? "waiting for the first episode…" : "no metrics recorded" }));
      return;
    }
    const win = windowFor(n);
    curve.dataset.window = String(win);
    const per = shown.stride > 1 ? " points (" + win * shown.stride + " episodes)" : "";
    const series = win > 1 ? [
      { name: "episodic return", key: RETURN, xs: rec.x, ys: rec.ret, cls: "raw", axis: "left" },
      { name: "return, mean of " + win + per, key: RETURN, xs: rec.x, ys: smooth(rec.ret, win), cls: "ret",
        axis: "left" },
    ] : [{ name: "episodic return", key: RETURN, xs: rec.x, ys: rec.ret, cls: "ret", axis: "left" }];
    if (rec.evalY.length) {
      series.push({ name: "greedy success", key: "eval/success_rate", xs: rec.evalX, ys: rec.evalY, cls: "succ",
        axis: "right", dots: true });
    } else if (rec.success.some(function (v) { return v !== null; })) {
      series.push({ name: win > 1 ? "training success, mean of " + win : "training success", key: "charts/success",
        xs: rec.x,
        ys: smooth(rec.success, win),
        cls: "succ dashed", axis: "right" });
    }
    const width = Math.max(320, curve.clientWidth || 800);
    curve.replaceChildren(chart({
      width: width, height: 280, title: "learning curve", xLabel: rec.stepAxis ? "env steps" : "episode",
      left: { label: "episodic return" }, right: { label: "success rate", range: [0, 1] }, series: series,
    }));
  }

  function drawDiagnostics() {
    const n = rec.episode.length;
    panels.dataset.points = String(n);
    panels.dataset.window = String(windowFor(n)); // the trailing mean each diagnostic line is drawn with
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
        // greedy evaluations (eval/…) are sparse: their own values as dots, not a trailing mean
        if (s[0].indexOf("eval/") === 0) {
          return { name: s[1], key: s[0], xs: rec.x, ys: rec.dual[s[0]], cls: "d" + i, axis: "left", dots: true };
        }
        return { name: s[1], key: s[0], xs: rec.x, ys: smooth(rec.dual[s[0]], win), cls: "d" + i, axis: "left" };
      });
      const box = document.createElement("figure");
      box.className = "panel";
      box.dataset.keys = g.series.map(function (s) { return s[0]; }).join(" ");
      box.appendChild(chart({ width: width, height: 190, title: g.title, xLabel: rec.stepAxis ? "env steps" : "episode",
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
    // the thinned series first: a long run's page stays small (every k-th episode, the ends, every evaluation)
    const series = await charts.loadSeries(jobId, POINTS);
    if (!series.error) {
      rec = series.rec;
      shown = { episodes: series.episodes, stride: series.stride };
    }
    draw();
  }

  async function loadFullResolution() {
    // every record, in pages of GET /jobs/{id}/metrics
    fullButton.disabled = true;
    fullButton.textContent = "loading every episode…";
    const full = charts.columns();
    let since = 0;
    for (;;) {
      const result = await window.dualsys.api("GET", "/jobs/" + jobId + "/metrics?since=" + since + "&limit=" + PAGE);
      if (!result.ok || !result.body) break;
      result.body.data.forEach(function (metric) { charts.addRecord(full, metric); });
      if (result.body.data.length < PAGE) break;
      since = full.episode[full.episode.length - 1];
    }
    rec = full;
    shown = { episodes: full.episode.length ? full.episode[full.episode.length - 1] : 0, stride: 1 };
    fullButton.disabled = false;
    fullButton.textContent = "full resolution";
    draw();
  }
  if (fullButton) fullButton.addEventListener("click", loadFullResolution);

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
