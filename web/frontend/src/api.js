// JSON requests to the viewer's REST endpoints; errors come back as {ok: false, error}.
export async function post(path, body) {
  const res = await fetch(path, { method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(body) });
  return res.json();
}

export async function get(path) {
  const res = await fetch(path);
  return res.json();
}
