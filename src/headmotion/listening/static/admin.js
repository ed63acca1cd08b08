// Admin page: progress of a listening test and result downloads.
// The admin link printed by `listen serve` (/admin?token=...) is traded by the server for an
// HttpOnly, SameSite=Strict session cookie and a redirect to /admin, so the token never stays in
// the address bar or the history.  This page only ever sends the cookie (same-origin fetches);
// the login form posts the token once, with the CSRF header the server requires on admin POSTs.
const $ = (s) => document.querySelector(s);

function csrf() {
  const m = document.cookie.match(/(?:^|;\s*)hm_csrf=([^;]+)/);
  return m ? decodeURIComponent(m[1]) : "";
}

async function post(path, body) {
  return fetch(path, {
    method: "POST", credentials: "same-origin",
    headers: { "Content-Type": "application/json", "X-CSRF-Token": csrf() },
    body: body === undefined ? undefined : JSON.stringify(body),
  });
}

async function show() {
  const r = await fetch("/api/admin/progress", { credentials: "same-origin" });
  if (r.status === 401) { $("#login").hidden = false; $("#logout").hidden = true; return false; }
  if (!r.ok) { $("#summary").textContent = `Error ${r.status}`; return false; }
  $("#login").hidden = true;
  $("#logout").hidden = false;
  const d = await r.json();
  $("#summary").textContent =
    `${d.test} (${d.type}): ${d.n_participants} participants, ${d.n_finished} finished, ${d.n_answers} answers`;
  for (const [id, ext] of [["#dl-csv", "csv"], ["#dl-json", "json"]]) {
    $(id).onclick = async (e) => {
      e.preventDefault();
      const resp = await fetch(`/api/admin/results.${ext}`, { credentials: "same-origin" });
      if (!resp.ok) { $("#summary").textContent = `Error ${resp.status}`; return; }
      const url = URL.createObjectURL(await resp.blob());
      const a = Object.assign(document.createElement("a"), { href: url, download: `${d.test}-results.${ext}` });
      document.body.append(a); a.click(); a.remove();
      setTimeout(() => URL.revokeObjectURL(url), 10000);
    };
  }
  $("#downloads").hidden = false;
  const rows = d.participants.map((p) =>
    `<tr><td>${p.id}</td><td>${new Date(p.created_at * 1000).toISOString()}</td><td>${escapeHtml(p.stage)}</td>` +
    `<td>${p.next_trial} / ${p.n_trials}</td><td>${escapeHtml(JSON.stringify(p.demographics))}</td></tr>`);
  $("#table").innerHTML = "<tr><th>#</th><th>started</th><th>stage</th><th>progress</th><th>demographics</th></tr>" + rows.join("");
  return true;
}
function escapeHtml(s) { return String(s).replace(/[&<>"']/g, (c) => `&#${c.charCodeAt(0)};`); }

$("#login").addEventListener("submit", async (e) => {
  e.preventDefault();
  const r = await post("/api/admin/session", { token: $("#token").value.trim() });
  $("#token").value = "";
  if (!r.ok) { $("#summary").textContent = r.status === 401 ? "Wrong token." : `Error ${r.status}`; return; }
  show();
});
$("#logout").addEventListener("click", async () => {
  await post("/api/admin/logout");
  $("#downloads").hidden = true; $("#table").innerHTML = ""; $("#summary").textContent = "Logged out.";
  $("#login").hidden = false; $("#logout").hidden = true;
});
show();
