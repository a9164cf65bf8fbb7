// Submit forms (jobs page: a training job; experiments page: an experiment file). Each is a REST call
// with the tab's bearer token (POST /jobs, POST /experiments); a refusal shows the API's own message
// beside the field it names (`errors[].field`, e.g. spec.episodes or content.seeds: the field whose
// data-field is that name or the longest prefix of it), and the whole answer under the button.
"use strict";

(function () {
  function fieldsOf(form) {
    return Array.from(form.querySelectorAll("[data-field]"));
  }

  function clearErrors(form) {
    form.querySelectorAll(".field-error").forEach(function (node) { node.remove(); });
    fieldsOf(form).forEach(function (input) { input.removeAttribute("aria-invalid"); });
  }

  function showError(form, field, message) {
    // the input named by `field`, or by its longest prefix (spec.overrides.agent.x → spec.overrides)
    let target = null;
    fieldsOf(form).forEach(function (input) {
      const name = input.dataset.field;
      if ((field === name || field.indexOf(name + ".") === 0) && (!target || name.length > target.dataset.field.length)) {
        target = input;
      }
    });
    if (!target) return false;
    target.setAttribute("aria-invalid", "true");
    const note = Object.assign(document.createElement("span"), { className: "field-error", textContent: message });
    note.dataset.errorFor = target.dataset.field;
    const label = target.closest("label");
    if (label) label.appendChild(note); // under the field, inside its label
    else target.insertAdjacentElement("afterend", note);
    return true;
  }

  function value(input) {
    // the JSON value of a field; undefined when left empty (the service keeps its default)
    const text = input.value.trim();
    if (text === "") return undefined;
    const type = input.dataset.type;
    if (type === "int" || type === "number") return Number(text);
    if (type === "json") return JSON.parse(text);
    return text;
  }

  function body(form) {
    const values = {};
    for (const input of fieldsOf(form)) {
      let v;
      try {
        v = value(input);
      } catch (error) {
        return { error: { field: input.dataset.field, message: "not JSON: " + error.message } };
      }
      if (v !== undefined) values[input.name] = v;
    }
    if (form.dataset.kind === "train") return { body: { kind: "train", spec: values }, path: "/jobs" };
    return { body: values, path: "/experiments" };
  }

  async function submit(form) {
    const out = form.querySelector("[data-result]");
    clearErrors(form);
    const request = body(form);
    if (request.error) {
      showError(form, request.error.field, request.error.message);
      out.textContent = "not sent: " + request.error.field + " " + request.error.message;
      out.className = "result refused";
      return;
    }
    out.textContent = "…";
    out.className = "result";
    const result = await window.dualsys.api("POST", request.path, request.body);
    if (!result.ok) {
      ((result.body && result.body.errors) || []).forEach(function (e) { showError(form, e.field, e.message); });
      window.dualsys.showResult(out, result, "");
      return;
    }
    out.replaceChildren();
    out.className = "result ok";
    if (form.dataset.kind === "train") {
      const link = Object.assign(document.createElement("a"), { href: "/ui/jobs/" + result.body.id, textContent: "job " + result.body.id });
      link.dataset.jobId = String(result.body.id);
      out.append(link, " " + result.body.status + " (HTTP " + result.status + ")");
    } else {
      const link = Object.assign(document.createElement("a"), {
        href: "/ui/experiments/" + result.body.id, textContent: "experiment " + result.body.id + " " + result.body.name,
      });
      link.dataset.experimentId = String(result.body.id);
      out.append(link, ": " + result.body.cells.total + " cells queued");
      document.dispatchEvent(new CustomEvent("dualsys:experiment-submitted"));
    }
  }

  document.querySelectorAll("form.submit-form").forEach(function (form) {
    form.addEventListener("submit", function (event) {
      event.preventDefault();
      submit(form);
    });
  });

  const file = document.getElementById("experiment-file");
  if (file) {
    file.addEventListener("change", function () {
      const chosen = file.files && file.files[0];
      if (!chosen) return;
      chosen.text().then(function (text) {
        document.querySelector('#submit-experiment textarea[name="content"]').value = text;
      });
    });
  }
})();
