// The report's scenario-editor profiles (JSON, appendix C.3) out of and into the editor; the server converts both
// ways, so a profile the page writes is one `lunarsim scenario import` reads.
import { post } from "./api.js";

const $ = (id) => document.getElementById(id);

export async function exportProfile(ed) {
  const r = await ed.call("/api/profile/export");
  if (!r || !r.ok) return;
  const a = document.createElement("a");
  a.href = URL.createObjectURL(new Blob([JSON.stringify(r.profile, null, 1)], { type: "application/json" }));
  a.download = `${$("ed-name").value || "scenario"}.json`;
  document.body.appendChild(a);
  a.click();
  a.remove();
  ed.status(`exported profile ${a.download} (profiles carry no obstacles, terrain or parameters)`, true);
}

export async function importProfile(ed, file) {
  if (!file) return;
  let profile;
  try { profile = JSON.parse(await file.text()); } catch (err) { ed.status(`${file.name}: not JSON: ${err.message}`, false); return; }
  const r = await post("/api/profile/import", { profile, name: file.name.replace(/\.json$/, "") });
  if (r.ok) { ed.load(r.scenario); ed.status(`imported profile ${file.name}`, true); } else ed.status(r.error, false);
}
