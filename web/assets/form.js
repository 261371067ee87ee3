// What the vehicle's own page (app.js) and the topside's page share: the commander's form, built
// from a message type's form schema (/api/commander) and read back into the JSON the server then
// checks again (the form only flags; the interface's gates decide), and the scope's field tree.
// No library.
"use strict";
window.FrontseatForm = (function () {
  function el(tag, attrs, ...kids) {
    const e = document.createElement(tag);
    for (const [k, v] of Object.entries(attrs || {})) {
      if (k === "class") e.className = v; else if (k.startsWith("on")) e.addEventListener(k.slice(2), v); else e.setAttribute(k, v);
    }
    for (const k of kids) if (k !== null && k !== undefined) e.append(k instanceof Node ? k : String(k));
    return e;
  }
  // A message as nested lists, one item per field (`data-field` names it), for the scopes.
  function tree(v) {
    if (v === null || typeof v !== "object") return el("span", {}, JSON.stringify(v));
    const ul = el("ul", { class: "tree" });
    for (const [k, x] of Object.entries(v)) {
      const li = el("li", { "data-field": k }, el("span", { class: "k" }, k + ": "));
      li.append(typeof x === "object" && x !== null ? tree(x) : el("span", { class: "v" }, JSON.stringify(x)));
      ul.append(li);
    }
    return ul;
  }
  const INT_RANGES = { int32: [-2147483648, 2147483647], uint32: [0, 4294967295], int64: [-9007199254740991, 9007199254740991], uint64: [0, 9007199254740991] };
  function fieldsOf(schema, prefix, onChange) {
    const box = el("div", {});
    for (const f of schema.fields) {
      const path = prefix + f.name;
      if (f.type === "message") {
        if (f.label === "repeated" || !f.message) continue;
        const fs = el("fieldset", { "data-message": path }, el("legend", {}, f.name + (f.label === "required" ? " *" : "") + " (" + f.message.type + ")"));
        fs.append(fieldsOf(f.message, path + ".", onChange));
        box.append(fs);
        continue;
      }
      let input;
      const def = f.default === null || f.default === undefined ? "" : String(f.default);
      if (f.type === "enum") {
        input = el("select", { name: path, "data-type": "enum" }, el("option", { value: "", class: "default" }, def ? "(default " + def + ")" : "(unset)"));
        for (const v of f.enum) input.append(el("option", { value: v.name }, v.name));
      } else if (f.type === "bool") {
        input = el("select", { name: path, "data-type": "bool" }, el("option", { value: "" }, "(default " + (def || "false") + ")"), el("option", { value: "true" }, "true"), el("option", { value: "false" }, "false"));
      } else {
        input = el("input", { name: path, "data-type": f.type, placeholder: def, "data-label": f.label });
        if (f.label === "repeated") input.setAttribute("placeholder", "comma-separated");
      }
      input.dataset.label = f.label;
      input.addEventListener("input", onChange); input.addEventListener("change", onChange);
      const extra = f.name === "time" ? el("button", { type: "button", onclick: () => { input.value = (Date.now() / 1000).toFixed(3); onChange(); } }, "now") : "";
      box.append(el("div", { class: "field" }, el("label", { class: f.label === "required" ? "req" : "" }, f.name), input, el("span", { class: "muted" }, f.unit || ""), extra));
    }
    return box;
  }
  // Builds the JSON to send and flags bad fields; returns {message, errors}.
  function collect(form, limitFor) {
    const message = {}; const errors = [];
    for (const input of form.querySelectorAll("[name]")) {
      const path = input.name; const type = input.dataset.type; const raw = input.value.trim();
      input.classList.remove("bad");
      const bad = (why) => { input.classList.add("bad"); errors.push(path + ": " + why); };
      if (raw === "") {
        const parent = path.includes(".") ? path.slice(0, path.lastIndexOf(".")) : null;
        const parentUsed = parent === null || [...form.querySelectorAll("[name^='" + parent + ".']")].some((i) => i.value.trim() !== "");
        if (input.dataset.label === "required" && parentUsed) bad("required");
        continue;
      }
      let value;
      if (type === "enum") value = raw;
      else if (type === "bool") value = raw === "true";
      else if (type === "string") value = raw;
      else if (type === "bytes") value = btoa(raw);
      else if (input.dataset.label === "repeated") value = raw.split(",").map((s) => Number(s.trim()));
      else {
        value = Number(raw);
        if (!Number.isFinite(value)) { bad("not a number"); continue; }
        const range = INT_RANGES[type];
        if (range && (!Number.isInteger(value) || value < range[0] || value > range[1])) { bad("not a " + type); continue; }
        const lim = limitFor(path);
        if (lim && ((lim.min !== undefined && value < lim.min) || (lim.max !== undefined && value > lim.max))) { bad("outside [" + lim.min + ", " + lim.max + "]"); continue; }
      }
      let o = message; const parts = path.split(".");
      for (const p of parts.slice(0, -1)) o = (o[p] = o[p] || {});
      o[parts[parts.length - 1]] = value;
    }
    return { message, errors };
  }
  return { el, tree, fieldsOf, collect };
})();
