// Admin page: progress of a listening test and result downloads (token-protected API).
const $ = (s) => document.querySelector(s);
const params = new URLSearchParams(location.search);
if (params.get("token")) $("#token").value = params.get("token");

async function show() {
  const token = $("#token").value.trim();
  const r = await fetch("/api/admin/progress", { headers: { Authorization: `Bearer ${token}` } });
  if (!r.ok) { $("#summary").textContent = `Error ${r.status}: wrong token?`; return; }
  const d = await r.json();
  $("#summary").textContent =
    `${d.test} (${d.type}): ${d.n_participants} participants, ${d.n_finished} finished, ${d.n_answers} answers`;
  for (const [id, ext] of [["#dl-csv", "csv"], ["#dl-json", "json"]]) {
    // fetched with the token in a header (not in the URL, which would land in the history)
    $(id).onclick = async (e) => {
      e.preventDefault();
      const resp = await fetch(`/api/admin/results.${ext}`, { headers: { Authorization: `Bearer ${token}` } });
      if (!resp.ok) { $("#summary").textContent = `Error ${resp.status}`; return; }
      const url = URL.createObjectURL(await resp.blob());
      const a = Object.assign(document.createElement("a"), { href: url, download: `${d.test}-results.${ext}` });
      document.body.append(a); a.click(); a.remove();
      setTimeout(() => URL.revokeObjectURL(url), 10000);
    };
  }
  $("#downloads").hidden = false;
  const rows = d.participants.map((p) =>
    `<tr><td>${p.id}</td><td>${new Date(p.created_at * 1000).toISOString()}</td><td>${p.stage}</td>` +
    `<td>${p.next_trial} / ${p.n_trials}</td><td>${escapeHtml(JSON.stringify(p.demographics))}</td></tr>`);
  $("#table").innerHTML = "<tr><th>#</th><th>started</th><th>stage</th><th>progress</th><th>demographics</th></tr>" + rows.join("");
}
function escapeHtml(s) { return s.replace(/[&<>"']/g, (c) => `&#${c.charCodeAt(0)};`); }
$("#login").addEventListener("submit", (e) => { e.preventDefault(); show(); });
if ($("#token").value) show();
