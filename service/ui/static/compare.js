// Compare page: several jobs' learning curves overlaid on env steps (episodic return, smoothed with the
// slider's trailing window; greedy success), from each job's thinned series (GET /jobs/{id}/series).
"use strict";

(function () {
  const charts = window.dualsys.charts;
  const data = window.dualsys.pageData();
  const jobs = data.jobs || [];
  const slider = document.getElementById("smoothing");
  const sliderText = document.getElementById("smoothing-text");
  const returns = document.getElementById("compare-return");
  const success = document.getElementById("compare-success");
  const loaded = []; // {job, index, rec, stride, episodes}

  function message(host, text) {
    host.replaceChildren(Object.assign(document.createElement("p"), { className: "muted", textContent: text }));
    host.dataset.curves = "0";
  }

  function draw() {
    const win = Number(slider.value);
    const strides = loaded.map(function (l) { return l.stride; });
    const most = strides.length ? Math.max.apply(null, strides) : 1;
    sliderText.textContent = "trailing mean of " + win + " points" + (most > 1 ? " (up to " + win * most + " episodes)" : "");
    const withData = loaded.filter(function (l) { return l.rec.episode.length; });
    if (!withData.length) {
      message(returns, jobs.length ? "no metrics recorded yet" : "no jobs chosen");
      message(success, jobs.length ? "no metrics recorded yet" : "no jobs chosen");
      return;
    }
    const width = Math.max(360, returns.clientWidth || 900);
    const lines = withData.map(function (l) {
      return { name: l.job.label, key: l.job.id, xs: l.rec.x, ys: charts.smooth(l.rec.ret, win),
        cls: charts.colour(l.index), axis: "left" };
    });
    returns.replaceChildren(charts.chart({ width: width, height: 320, title: "episodic return",
      xLabel: "env steps", left: { label: "episodic return" }, right: null, series: lines }));
    returns.dataset.curves = String(lines.length);
    const rates = withData.map(function (l) {
      if (l.rec.evalY.length) {
        return { name: l.job.label, key: l.job.id, xs: l.rec.evalX, ys: l.rec.evalY, cls: charts.colour(l.index),
          axis: "left", dots: true };
      }
      return { name: l.job.label + " (training)", key: l.job.id, xs: l.rec.x, ys: charts.smooth(l.rec.success, win),
        cls: charts.colour(l.index) + " dashed", axis: "left" };
    });
    success.replaceChildren(charts.chart({ width: width, height: 240, title: "success rate", xLabel: "env steps",
      left: { label: "success rate", range: [0, 1] }, right: null, series: rates }));
    success.dataset.curves = String(rates.length);
  }

  async function load() {
    if (!jobs.length) { draw(); return; }
    const results = await Promise.all(jobs.map(function (job) { return charts.loadSeries(job.id, 1000); }));
    results.forEach(function (result, index) {
      const row = document.querySelector('#compared tr[data-job-id="' + jobs[index].id + '"] td.episodes');
      if (result.error) {
        if (row) row.textContent = result.error;
        return;
      }
      if (row) row.textContent = String(result.episodes);
      loaded.push({ job: jobs[index], index: index, rec: result.rec, stride: result.stride, episodes: result.episodes });
    });
    document.querySelectorAll("#compared .swatch-box").forEach(function (box) {
      box.classList.add(charts.colour(Number(box.dataset.index)));
    });
    draw();
  }

  slider.addEventListener("input", draw);
  let resizeTimer = null;
  window.addEventListener("resize", function () {
    window.clearTimeout(resizeTimer);
    resizeTimer = window.setTimeout(draw, 200);
  });
  load();
})();
