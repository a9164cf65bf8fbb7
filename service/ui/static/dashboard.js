// dualsys dashboard: what every page shares. The bearer token the person types is kept in this
// tab's sessionStorage and sent as `Authorization: Bearer ...` on actions; the REST API decides.
"use strict";

(function () {
  const KEY = "dualsys.token";
  const input = document.getElementById("token");
  const state = document.getElementById("token-state");

  function token() {
    return (input && input.value.trim()) || sessionStorage.getItem(KEY) || "";
  }

  function showState() {
    if (state) state.textContent = token() ? "set (this tab only)" : "kept in this tab only";
  }

  if (input) {
    input.value = sessionStorage.getItem(KEY) || "";
    input.addEventListener("input", function () {
      const value = input.value.trim();
      if (value) sessionStorage.setItem(KEY, value);
      else sessionStorage.removeItem(KEY);
      showState();
    });
    document.getElementById("token-form").addEventListener("submit", function (event) {
      event.preventDefault();
    });
    showState();
  }

  // Calls the REST API; resolves to {ok, status, body, message}. `message` is what the page shows:
  // the API's own `detail` on refusal (e.g. "HTTP 401: missing or invalid bearer token ...").
  async function api(method, path, body) {
    const headers = { Accept: "application/json" };
    const value = token();
    if (value) headers.Authorization = "Bearer " + value;
    if (body !== undefined) headers["Content-Type"] = "application/json";
    let response;
    try {
      response = await fetch(path, {
        method: method,
        headers: headers,
        body: body === undefined ? undefined : JSON.stringify(body),
        cache: "no-store",
      });
    } catch (error) {
      return { ok: false, status: 0, body: null, message: "network error: " + error.message };
    }
    let parsed = null;
    const text = await response.text();
    try {
      parsed = text ? JSON.parse(text) : null;
    } catch (error) {
      parsed = null;
    }
    let message = "HTTP " + response.status;
    if (parsed && typeof parsed.detail === "string") message += ": " + parsed.detail;
    return { ok: response.ok, status: response.status, body: parsed, message: message };
  }

  function pageData() {
    const node = document.getElementById("page-data");
    return node ? JSON.parse(node.textContent || "{}") : {};
  }

  function showResult(node, result, okText) {
    if (!node) return;
    node.textContent = result.ok ? okText : result.message;
    node.className = "result " + (result.ok ? "ok" : "refused");
  }

  window.dualsys = { token: token, api: api, pageData: pageData, showResult: showResult };
})();
