// Policy page: move or delete an alias, set a tag. Each is a REST call with the tab's bearer token;
// a refusal shows the API's answer as it is.
"use strict";

(function () {
  const data = window.dualsys.pageData();
  const name = encodeURIComponent(data.policy || "");
  const aliasForm = document.getElementById("alias-form");
  const tagForm = document.getElementById("tag-form");

  function field(form, key) {
    return form.elements.namedItem(key).value.trim();
  }

  async function act(form, method, path, body, okText) {
    const out = form.querySelector(".result");
    out.textContent = "…";
    const result = await window.dualsys.api(method, path, body);
    window.dualsys.showResult(out, result, okText);
    if (result.ok) window.setTimeout(function () { window.location.reload(); }, 600);
  }

  if (aliasForm) {
    aliasForm.addEventListener("submit", function (event) {
      event.preventDefault();
      const alias = field(aliasForm, "alias");
      const version = parseInt(field(aliasForm, "version"), 10);
      act(aliasForm, "PUT", "/policies/" + name + "/aliases/" + encodeURIComponent(alias),
        { version: version }, "alias " + alias + " → v" + version);
    });
    document.getElementById("alias-delete").addEventListener("click", function () {
      const alias = field(aliasForm, "alias");
      if (!alias) return;
      act(aliasForm, "DELETE", "/policies/" + name + "/aliases/" + encodeURIComponent(alias),
        undefined, "alias " + alias + " deleted");
    });
  }

  if (tagForm) {
    tagForm.addEventListener("submit", function (event) {
      event.preventDefault();
      const version = field(tagForm, "version");
      const key = field(tagForm, "key");
      act(tagForm, "PUT", "/policies/" + name + "/versions/" + encodeURIComponent(version) + "/tags/" +
        encodeURIComponent(key), { value: tagForm.elements.namedItem("value").value }, "tag set");
    });
  }
})();
