// Jobs page: the filters submit on change, and the table's rows are re-fetched from
// /ui/jobs/rows (rendered and escaped by the server) at most once a second while the tab is visible.
// Ticked rows stay ticked across refreshes; "Compare" opens /ui/compare with their ids.
"use strict";

(function () {
  const PERIOD_MS = 1000;
  const form = document.getElementById("filters");
  const live = document.getElementById("jobs-live");
  const label = document.getElementById("live-state");
  if (!live) return;

  form.querySelectorAll("select").forEach(function (select) {
    select.addEventListener("change", function () {
      form.submit();
    });
  });

  const query = new URLSearchParams();
  if (live.dataset.status) query.set("status", live.dataset.status);
  if (live.dataset.kind) query.set("kind", live.dataset.kind);
  if (live.dataset.experiment) query.set("experiment_id", live.dataset.experiment);
  query.set("page", live.dataset.page || "1");
  const url = "/ui/jobs/rows?" + query.toString();
  let last = null;
  let busy = false;
  const chosen = [];
  const compare = document.getElementById("compare-button");

  function showChosen() {
    live.querySelectorAll("input.pick").forEach(function (box) {
      box.checked = chosen.indexOf(box.value) >= 0;
    });
    compare.disabled = chosen.length === 0;
    compare.textContent = chosen.length ? "Compare " + chosen.length + " chosen job" + (chosen.length > 1 ? "s" : "")
      : "Compare chosen jobs";
  }

  live.addEventListener("change", function (event) {
    const box = event.target;
    if (!box.classList || !box.classList.contains("pick")) return;
    const at = chosen.indexOf(box.value);
    if (box.checked && at < 0) chosen.push(box.value);
    if (!box.checked && at >= 0) chosen.splice(at, 1);
    showChosen();
  });
  compare.addEventListener("click", function () {
    if (chosen.length) window.location.href = "/ui/compare?jobs=" + chosen.join(",");
  });

  function hasLiveRows() {
    return live.querySelector('tr[data-status="queued"], tr[data-status="running"]') !== null;
  }

  async function refresh() {
    if (busy || document.hidden) return;
    // page 1 shows new jobs as they are submitted; later pages only change while a row is live
    if (live.dataset.page !== "1" && !hasLiveRows()) {
      label.textContent = "";
      return;
    }
    busy = true;
    try {
      const response = await fetch(url, { cache: "no-store" });
      if (response.ok) {
        const html = await response.text();
        if (html !== last) {
          last = html;
          live.innerHTML = html;
          showChosen();
        }
        label.textContent = "live";
        label.className = "live-state on";
      } else {
        label.textContent = "refresh failed: HTTP " + response.status;
        label.className = "live-state off";
      }
    } catch (error) {
      label.textContent = "service unreachable";
      label.className = "live-state off";
    } finally {
      busy = false;
    }
  }

  window.setInterval(refresh, PERIOD_MS);
  document.addEventListener("visibilitychange", refresh);
})();
