// The incident commander's page: one EventSource for the picture, fetch for commands.
// Plain JavaScript, no framework and no build: the console binary serves this file as is.
//
// The stream opens with the whole picture (`incident`) and then sends what changed
// (`delta`), whole entities each time, so applying a delta is replacing entries by id.
// Freshness is aged here, on this page's clock: a page or console cut off shows every
// unit going stale rather than a map that looks current.

const STALE_MS = 2000;
const SVG = "http://www.w3.org/2000/svg";
const $ = (id) => document.getElementById(id);

const state = {
  seq: -1, t: 0, site: null, coordinator: null, me: null, selectedZone: null,
  units: new Map(), fires: new Map(), goals: [], decisions: [], alerts: new Map(),
  heat: null, clockSkew: 0,
};

// What the browser test and the latency measurement read: update latency from the
// console hearing a unit's state to this page having drawn it.
window.ffStats = { latency_ms: [], deltas: 0, incidents: 0 };

const el = (tag, attrs = {}, parent = null) => {
  const e = document.createElementNS(SVG, tag);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
  if (parent) parent.appendChild(e);
  return e;
};
const pt = ([x, y]) => `${x},${-y}`;
const fmt = (v, d = 1) => (v == null ? "-" : Number(v).toFixed(d));

// ---- the map -------------------------------------------------------------------------

let view = { x: 0, y: 0, w: 100, h: 20 };

function fitView() {
  const s = state.site;
  const xs = [...s.left_wall, ...s.right_wall].map((p) => p[0]);
  const ys = [...s.left_wall, ...s.right_wall].map((p) => -p[1]);
  const pad = 3;
  const x0 = Math.min(...xs) - pad, x1 = Math.max(...xs) + pad;
  const y0 = Math.min(...ys) - pad, y1 = Math.max(...ys) + pad;
  const box = $("map").getBoundingClientRect();
  const aspect = box.width / Math.max(box.height, 1);
  let w = x1 - x0, h = y1 - y0;
  if (w / h > aspect) h = w / aspect; else w = h * aspect;
  view = { x: (x0 + x1 - w) / 2, y: (y0 + y1 - h) / 2, w, h };
  applyView();
}

function applyView() {
  $("map").setAttribute("viewBox", `${view.x} ${view.y} ${view.w} ${view.h}`);
}

function setupPanZoom() {
  const svg = $("map");
  svg.addEventListener("wheel", (ev) => {
    ev.preventDefault();
    const box = svg.getBoundingClientRect();
    const fx = (ev.clientX - box.left) / box.width, fy = (ev.clientY - box.top) / box.height;
    const k = ev.deltaY > 0 ? 1.2 : 1 / 1.2;
    const w = view.w * k, h = view.h * k;
    view = { x: view.x + (view.w - w) * fx, y: view.y + (view.h - h) * fy, w, h };
    applyView();
  }, { passive: false });
  let drag = null;
  svg.addEventListener("pointerdown", (ev) => { drag = { x: ev.clientX, y: ev.clientY, moved: false }; });
  svg.addEventListener("pointermove", (ev) => {
    if (!drag) return;
    const box = svg.getBoundingClientRect();
    const dx = (ev.clientX - drag.x) * view.w / box.width, dy = (ev.clientY - drag.y) * view.h / box.height;
    if (Math.abs(ev.clientX - drag.x) + Math.abs(ev.clientY - drag.y) > 3) drag.moved = true;
    if (drag.moved) {
      view.x -= dx; view.y -= dy; drag.x = ev.clientX; drag.y = ev.clientY; applyView();
    }
  });
  svg.addEventListener("pointerup", () => { setTimeout(() => { drag = null; }, 0); });
  svg.addEventListener("click", (ev) => { if (drag && drag.moved) ev.stopPropagation(); }, true);
  window.addEventListener("resize", () => state.site && fitView());
}

function drawSite() {
  const s = state.site;
  $("scenario").textContent = `${s.scenario} (site ${s.site}, ${fmt(s.length_m, 0)} m)`;
  for (const id of ["heat", "zones", "walls", "rails", "obstacles", "fires", "units"]) $(id).replaceChildren();
  unitEls.clear(); fireEls.clear();
  const defs = el("defs", {}, $("zones"));
  const hatch = el("pattern", { id: "hatch-keep-out", width: 1.2, height: 1.2, patternUnits: "userSpaceOnUse", patternTransform: "rotate(45)" }, defs);
  el("rect", { width: 1.2, height: 1.2, fill: "rgba(255,77,79,0.18)" }, hatch);
  el("rect", { width: 0.5, height: 1.2, fill: "rgba(255,77,79,0.55)" }, hatch);
  for (const z of s.zones) {
    const g = el("g", { "data-zone": z.id }, $("zones"));
    const poly = el("polygon", { class: "zone", points: z.outline.map(pt).join(" "), "data-zone": z.id }, g);
    poly.addEventListener("click", () => selectZone(z.id));
    el("text", { class: "zone-label", x: z.label[0], y: -z.label[1] + 4 }, g).textContent = z.id;
    el("text", { class: "zone-goal", x: z.label[0], y: -z.label[1] - 3 }, g);
  }
  el("polyline", { class: "wall", points: s.left_wall.map(pt).join(" ") }, $("walls"));
  el("polyline", { class: "wall", points: s.right_wall.map(pt).join(" ") }, $("walls"));
  el("polyline", { class: "centre", points: s.centre.map(pt).join(" ") }, $("walls"));
  for (const r of s.rails) {
    el("polyline", { class: "rail", points: r.line.map(pt).join(" ") }, $("rails"));
    for (const h of r.hose_points) el("circle", { class: "hose", cx: h[0], cy: -h[1], r: 0.3 }, $("rails"));
  }
  for (const o of s.obstacles) {
    el("polygon", { class: "obstacle", points: o.corners.map(pt).join(" ") }, $("obstacles")).appendChild(title(o.name));
  }
  const select = $("goal-zone");
  select.replaceChildren(...s.zones.map((z) => new Option(`${z.id} (${fmt(z.start_m, 0)}-${fmt(z.end_m, 0)} m)`, z.id)));
  select.onchange = () => selectZone(select.value);
  fitView();
}

function title(text) {
  const t = document.createElementNS(SVG, "title");
  t.textContent = text;
  return t;
}

function selectZone(id) {
  state.selectedZone = id;
  $("goal-zone").value = id;
  for (const p of document.querySelectorAll("polygon.zone")) p.classList.toggle("selected", p.dataset.zone === id);
}

// The goal a zone shows: the highest priority in force there.
function zoneGoals() {
  const by = new Map();
  for (const g of state.goals) {
    const cur = by.get(g.goal.zone);
    if (!cur || g.goal.priority > cur.goal.priority) by.set(g.goal.zone, g);
  }
  return by;
}

function drawGoals() {
  const by = zoneGoals();
  for (const g of document.querySelectorAll("#zones g[data-zone]")) {
    const goal = by.get(g.dataset.zone);
    const kind = goal ? goal.goal.goal : "";
    const poly = g.querySelector("polygon");
    poly.setAttribute("class", `zone ${kind}` + (state.selectedZone === g.dataset.zone ? " selected" : ""));
    poly.dataset.goal = kind;
    g.querySelector(".zone-goal").textContent = goal ? `${kind.toUpperCase()} (${goal.goal.issued_by})` : "";
  }
  const list = $("goals");
  list.replaceChildren(...state.goals.map((g) => {
    const li = document.createElement("li");
    const until = g.until != null ? `, until t=${fmt(g.until, 0)} s` : "";
    li.textContent = `${g.goal.zone}: ${g.goal.goal} p${g.goal.priority} by ${g.goal.issued_by} since t=${fmt(g.since, 0)} s${until}`;
    li.dataset.zone = g.goal.zone; li.dataset.goal = g.goal.goal;
    return li;
  }));
  if (!state.goals.length) list.replaceChildren(Object.assign(document.createElement("li"), { textContent: "none" }));
}

function offset(i, d) {
  const s = state.site, c = s.centre[i], l = s.left_wall[i], half = s.width_m / 2;
  return [c[0] + (l[0] - c[0]) * d / half, c[1] + (l[1] - c[1]) * d / half];
}

function drawHeat() {
  const layer = $("heat");
  layer.replaceChildren();
  const h = state.heat, s = state.site;
  if (!h) return;
  const n = s.stations_m.length, cols = h.columns;
  const step = Math.max(1, Math.ceil(n / 500));
  const q = (i, j) => h.kw_m2[i * cols + j];
  for (let i = 0; i + step < n; i += step) {
    for (let j = 0; j + 1 < cols; j++) {
      const v = (q(i, j) + q(i + step, j) + q(i, j + 1) + q(i + step, j + 1)) / 4;
      if (v < 0.2) continue;
      const a = Math.min(1, v / 10);
      const pts = [offset(i, s.lateral_m[j]), offset(i + step, s.lateral_m[j]), offset(i + step, s.lateral_m[j + 1]), offset(i, s.lateral_m[j + 1])];
      el("polygon", { points: pts.map(pt).join(" "), fill: `rgba(255,${Math.round(160 - 120 * a)},0,${0.15 + 0.55 * a})` }, layer);
    }
  }
}

const fireEls = new Map();
const fireClass = (f) => ({ tentative: "tentative", confirmed: "burning", assigned: "burning", suppressing: "suppressing", out: "out", lost: "tentative" }[f.state] || "burning");

function drawFire(f) {
  let g = fireEls.get(f.id);
  if (!g) {
    g = el("g", { "data-fire": f.id }, $("fires"));
    el("circle", {}, g); el("text", {}, g); g.appendChild(title(""));
    fireEls.set(f.id, g);
  }
  // Area proportional to the heat release: 1 MW is a 1 m radius.
  const r = Math.max(0.5, Math.sqrt((f.hrr_kw || 500) / 1000));
  g.setAttribute("class", `fire ${fireClass(f)}`);
  g.dataset.state = f.state;
  const c = g.querySelector("circle");
  c.setAttribute("cx", f.position.x); c.setAttribute("cy", -f.position.y); c.setAttribute("r", r);
  const t = g.querySelector("text");
  t.setAttribute("x", f.position.x + r + 0.3); t.setAttribute("y", -f.position.y - r);
  t.textContent = `${f.id} ${f.state}`;
  g.querySelector("title").textContent = `${f.id}: ${f.state}, ${fmt((f.hrr_kw || 0) / 1000, 1)} MW, units ${f.assigned.join(", ") || "none"}`;
}

const unitEls = new Map();
const unitRows = new Map();

function unitStatus(u, now) {
  if (u.lost) return "lost";
  if (!u.state) return "unheard";
  return now - (u.heard_ms - state.clockSkew) > STALE_MS ? "stale" : "fresh";
}

function drawUnit(u, now) {
  const s = u.state;
  let g = unitEls.get(u.id);
  if (!s) { if (g) g.remove(); unitEls.delete(u.id); return; }
  if (!g) {
    g = el("g", { "data-unit": u.id }, $("units"));
    el("line", { class: "task" }, g);
    const body = el("g", {}, g);
    el("path", { d: s.kind === "monorail" ? "M 1 0 L 0 0.8 L -1 0 L 0 -0.8 Z" : "M 1.2 0 L -0.8 0.7 L -0.8 -0.7 Z" }, body);
    el("text", {}, g); g.appendChild(title(""));
    unitEls.set(u.id, g);
  }
  const status = unitStatus(u, now);
  g.setAttribute("class", `unit ${s.kind} ${status}` + (s.autonomous ? " autonomous" : "") + (s.mode === "fault" ? " fault" : ""));
  g.dataset.status = status;
  g.dataset.x = s.pose.x; g.dataset.y = s.pose.y;
  const deg = -s.pose.yaw * 180 / Math.PI;
  g.children[1].setAttribute("transform", `translate(${s.pose.x},${-s.pose.y}) rotate(${deg})`);
  const line = g.querySelector("line");
  if (s.task) {
    line.setAttribute("x1", s.pose.x); line.setAttribute("y1", -s.pose.y);
    line.setAttribute("x2", s.task.target.x); line.setAttribute("y2", -s.task.target.y);
    line.style.display = "";
  } else line.style.display = "none";
  const t = g.querySelector("text");
  t.setAttribute("x", s.pose.x + 1); t.setAttribute("y", -s.pose.y + 2);
  t.textContent = u.id;
  g.querySelector("title").textContent = `${u.id}: ${s.mode}${s.task ? ` on ${s.task.fire} (${s.task.phase})` : ""}, ${fmt(s.water_l, 0)} L`;
}

function unitRow(u, now) {
  let tr = unitRows.get(u.id);
  if (!tr) {
    tr = document.createElement("tr");
    tr.dataset.unit = u.id;
    for (let i = 0; i < 6; i++) tr.appendChild(document.createElement("td"));
    unitRows.set(u.id, tr);
    const rows = [...unitRows.keys()].sort();
    $("units-body").replaceChildren(...rows.map((k) => unitRows.get(k)));
  }
  const s = u.state, status = unitStatus(u, now), td = tr.children;
  tr.className = status; tr.dataset.status = status;
  td[0].textContent = u.id;
  td[1].textContent = s ? s.mode + (s.autonomous ? " (alone)" : "") + (s.refused ? " REFUSED" : "") : "-";
  td[2].textContent = s && s.task ? `${s.task.fire} ${s.task.phase}` : "-";
  td[3].textContent = s ? `${fmt(s.water_l, 0)} L` : "-";
  td[4].textContent = s ? `${fmt(s.heat_flux_kw_m2, 1)} kW/m²` : "-";
  td[5].textContent = status === "lost" ? "LOST" : (u.heard_ms == null ? "never" : `${fmt((now - (u.heard_ms - state.clockSkew)) / 1000, 1)} s ago`);
}

function fireRows() {
  const fires = [...state.fires.values()].sort((a, b) => a.id.localeCompare(b.id, undefined, { numeric: true }));
  $("fires-body").replaceChildren(...fires.map((f) => {
    const tr = document.createElement("tr");
    tr.dataset.fire = f.id; tr.dataset.state = f.state;
    for (const v of [f.id, f.state, f.hrr_kw != null ? `${fmt(f.hrr_kw / 1000, 1)} MW` : "-", `${fmt(f.position.x, 0)}, ${fmt(f.position.y, 0)}`, f.assigned.join(" ") || "-"]) {
      tr.appendChild(Object.assign(document.createElement("td"), { textContent: v }));
    }
    return tr;
  }));
}

function drawAlerts() {
  const alerts = [...state.alerts.values()].sort((a, b) => (a.acked_by == null) - (b.acked_by == null) || b.id - a.id).reverse();
  $("alerts").replaceChildren(...alerts.map((a) => {
    const li = document.createElement("li");
    li.className = a.acked_by ? "acked" : "open";
    li.dataset.alert = a.id; li.dataset.kind = a.kind;
    li.textContent = `t=${fmt(a.t, 0)} s ${a.text}` + (a.acked_by ? ` (acknowledged by ${a.acked_by})` : " ");
    if (!a.acked_by) {
      const b = document.createElement("button");
      b.textContent = "Acknowledge"; b.disabled = !state.steers;
      b.onclick = () => command("POST", `/api/alerts/${a.id}/ack`).then((r) => { if (!r.ok) $("ack").textContent = r.body.error; });
      li.appendChild(b);
    }
    return li;
  }));
  if (!alerts.length) $("alerts").replaceChildren(Object.assign(document.createElement("li"), { textContent: "none" }));
}

function drawDecisions(items) {
  const list = $("decisions");
  for (const d of items) {
    const li = document.createElement("li");
    li.textContent = `t=${fmt(d.t, 1)} s `;
    li.appendChild(Object.assign(document.createElement("span"), { textContent: d.text }));
    list.prepend(li);
  }
  while (list.children.length > 200) list.lastChild.remove();
}

function drawHeader() {
  $("clock").textContent = `t = ${fmt(state.t, 1)} s`;
  const c = $("coordinator");
  c.textContent = state.coordinator === true ? "coordinator up" : state.coordinator === false ? "NO COORDINATOR" : "coordinator ?";
  c.className = "badge " + (state.coordinator === true ? "ok" : state.coordinator === false ? "bad" : "");
}

// ---- applying the stream -------------------------------------------------------------

function applyIncident(inc) {
  state.seq = inc.seq; state.t = inc.t; state.coordinator = inc.coordinator;
  if (!state.site || state.site.stations_m.length !== inc.site.stations_m.length || state.site.scenario !== inc.site.scenario) {
    state.site = inc.site; drawSite();
  }
  state.units = new Map(inc.units.map((u) => [u.id, u]));
  state.fires = new Map(inc.fires.map((f) => [f.id, f]));
  state.goals = inc.goals; state.alerts = new Map(inc.alerts.map((a) => [a.id, a]));
  state.heat = inc.heat;
  $("units").replaceChildren(); unitEls.clear(); unitRows.clear(); $("units-body").replaceChildren();
  $("fires").replaceChildren(); fireEls.clear();
  $("decisions").replaceChildren();
  const now = Date.now();
  for (const u of state.units.values()) { drawUnit(u, now); unitRow(u, now); }
  for (const f of state.fires.values()) drawFire(f);
  fireRows(); drawGoals(); drawHeat(); drawAlerts(); drawDecisions(inc.decisions); drawHeader();
  window.ffStats.incidents++;
}

function applyDelta(d) {
  if (d.seq <= state.seq) return;
  state.seq = d.seq; state.t = d.t;
  if (d.coordinator != null) state.coordinator = d.coordinator;
  const now = Date.now();
  const heard = [];
  for (const u of d.units || []) {
    state.units.set(u.id, u); drawUnit(u, now); unitRow(u, now);
    if (u.heard_ms != null) heard.push(u.heard_ms);
  }
  if (d.fires) { for (const f of d.fires) { state.fires.set(f.id, f); drawFire(f); } fireRows(); }
  if (d.goals) { state.goals = d.goals; drawGoals(); }
  if (d.alerts) { for (const a of d.alerts) state.alerts.set(a.id, a); drawAlerts(); }
  if (d.heat) { state.heat = d.heat; drawHeat(); }
  if (d.decisions) drawDecisions(d.decisions);
  drawHeader();
  window.ffStats.deltas++;
  if (heard.length) {
    // Drawn once the browser has painted the frame with the change in it.
    requestAnimationFrame(() => setTimeout(() => {
      const drawn = Date.now();
      const l = window.ffStats.latency_ms;
      for (const h of heard) l.push(drawn - h);
      if (l.length > 20000) l.splice(0, l.length - 20000);
    }, 0));
  }
}

let source = null;

// The stream: the console refuses it (401) to a page nobody has logged in on when reads
// need a login; a refused EventSource closes for good, and logging in opens it again.
function connect() {
  if (source) source.close();
  const es = new EventSource("/api/stream");
  source = es;
  es.addEventListener("incident", (ev) => { applyIncident(JSON.parse(ev.data)); link(true); });
  es.addEventListener("delta", (ev) => applyDelta(JSON.parse(ev.data)));
  es.onerror = () => link(false, es.readyState === EventSource.CLOSED && !state.me);
}

function link(up, loginNeeded) {
  const l = $("link");
  l.textContent = up ? "live" : loginNeeded ? "log in to see the incident" : "NO LINK to the console";
  l.className = "badge " + (up ? "ok" : "bad");
}

// Ages every unit on this page's clock.
setInterval(() => {
  const now = Date.now();
  for (const u of state.units.values()) {
    unitRow(u, now);
    const g = unitEls.get(u.id);
    if (g && g.dataset.status !== unitStatus(u, now)) drawUnit(u, now);
  }
}, 500);

// ---- commands ------------------------------------------------------------------------

async function command(method, url, body) {
  const r = await fetch(url, {
    method, credentials: "same-origin",
    headers: body ? { "content-type": "application/json" } : {},
    body: body ? JSON.stringify(body) : undefined,
  });
  let json = {};
  try { json = await r.json(); } catch { json = { error: `${r.status} ${r.statusText}` }; }
  return { ok: r.ok, status: r.status, body: json };
}

function loggedIn(name, role) {
  state.me = name;
  const steers = !!name && role === "commander";
  state.steers = steers;
  $("login").hidden = !!name; $("who").hidden = !name;
  $("who-name").textContent = name ? `${steers ? "commander" : "viewer"} ${name}` : "";
  $("goal-issue").disabled = !steers; $("goal-clear").disabled = !steers;
  drawAlerts();
}

function setupCommands() {
  $("login").addEventListener("submit", async (ev) => {
    ev.preventDefault();
    $("login-error").textContent = "";
    const r = await command("POST", "/api/login", { name: $("login-name").value, password: $("login-password").value });
    $("login-password").value = "";
    if (r.ok) { loggedIn(r.body.name, r.body.role); connect(); } else $("login-error").textContent = r.body.error || "refused";
  });
  $("logout").addEventListener("click", async () => { await command("POST", "/api/logout"); loggedIn(null); });
  const kind = $("goal-kind");
  const showBefore = () => { $("goal-before-label").hidden = kind.value !== "contain"; };
  kind.addEventListener("change", showBefore); showBefore();
  $("goal-form").addEventListener("submit", async (ev) => {
    ev.preventDefault();
    const form = { zone: $("goal-zone").value, goal: kind.value, priority: Number($("goal-priority").value || 0), rail_allowed: $("goal-rail").checked };
    if (kind.value === "contain") form.before_m = Number($("goal-before").value);
    const ack = $("ack");
    ack.className = ""; ack.textContent = `issuing ${form.goal} on ${form.zone}...`;
    const r = await command("POST", "/api/goals", form);
    if (r.body.accepted === true) { ack.className = "accepted"; ack.textContent = `accepted: ${r.body.id}: ${r.body.reason}`; }
    else if (r.body.accepted === false) { ack.className = "rejected"; ack.textContent = `rejected: ${r.body.id}: ${r.body.reason}`; }
    else { ack.className = "rejected"; ack.textContent = `not issued: ${r.body.error}`; }
  });
  $("goal-clear").addEventListener("click", async () => {
    const zone = $("goal-zone").value;
    const r = await command("DELETE", `/api/goals/${encodeURIComponent(zone)}`);
    $("ack").className = r.ok ? "accepted" : "rejected";
    $("ack").textContent = r.ok ? `cleared your goals on ${zone}` : `not cleared: ${r.body.error}`;
  });
}

setupPanZoom();
setupCommands();
command("GET", "/api/me").then((r) => { loggedIn(r.ok ? r.body.name : null, r.ok ? r.body.role : null); connect(); });
