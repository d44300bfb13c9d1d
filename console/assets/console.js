// The incident commander's page: one EventSource for the picture, fetch for commands.
// Plain JavaScript, no framework and no build: the console binary serves this file as is.
//
// The stream opens with the whole picture (`incident`) and then sends what changed
// (`delta`): whole entities and decision lines, replaced by id, and units' moves, applied
// on top of the unit held. Freshness is aged here, on
// this page's clock: a page or console cut off shows every unit going stale rather than a
// map that looks current.
//
// The map is drawn in screen pixels over a world transform of our own (not an SVG
// viewBox): the tunnel's shapes scale with the zoom, while markers and labels keep a size
// a commander reads at arm's length, and labels are placed so that no two overlap (one
// that finds no free place is left out, and the count of those is shown). A 300 x 10 m
// tunnel fitted to a 1920 px window would be a band 47 px tall, so the view opens on the
// incident (its units and fires) and follows it until the commander pans or zooms; the
// strip above the map is the whole tunnel, with the view marked on it.
//
// The timeline keeps a snapshot of the map every second of site time; dragging it shows
// the incident as it was, decisions after that time dimmed. What happened before the page
// was opened comes from the console's own timeline (`/api/history`, kept on its host).

const STALE_MS = 2000;
const SVG = "http://www.w3.org/2000/svg";
const LABEL_FONT_PX = 12;
// As many as the console keeps (`history::MAX_SNAPSHOTS`).
const MAX_SNAPSHOTS = 3600;
const $ = (id) => document.getElementById(id);

const state = {
  seq: -1, t: 0, site: null, coordinator: null, standbys: null, link: null, me: null, steers: false,
  selectedZone: null, selectedUnit: null, units: new Map(), fires: new Map(), goals: [],
  decisions: new Map(), alerts: new Map(), heat: null, infra: null, clockSkew: 0,
};

// What the browser test and the latency measurement read: update latency from the
// console hearing a unit's state to this page having drawn it, and the labels' boxes.
window.ffStats = { latency_ms: [], deltas: 0, incidents: 0, labels_hidden: 0, historyLoaded: 0 };
window.ffState = state;

const el = (tag, attrs = {}, parent = null) => {
  const e = document.createElementNS(SVG, tag);
  for (const [k, v] of Object.entries(attrs)) e.setAttribute(k, v);
  if (parent) parent.appendChild(e);
  return e;
};
const html = (tag, props = {}, parent = null) => {
  const e = Object.assign(document.createElement(tag), props);
  if (parent) parent.appendChild(e);
  return e;
};
const fmt = (v, d = 1) => (v == null ? "-" : Number(v).toFixed(d));
function dur(s) {
  if (s == null) return "-";
  if (s < 90) return `${Math.round(s)} s`;
  const m = Math.floor(s / 60);
  return m < 90 ? `${m} min ${Math.round(s - 60 * m)} s` : `${(s / 3600).toFixed(1)} h`;
}
const title = (text) => { const t = document.createElementNS(SVG, "title"); t.textContent = text; return t; };

// ---- the site's geometry -------------------------------------------------------------

// The chainage of a site point: the nearest centreline station (the site map has one a
// metre, or fewer on a very long tunnel). Fires keep still: theirs are remembered.
const chainages = new Map();
function chainageOf(x, y) {
  const key = `${x},${y}`;
  if (chainages.has(key)) return chainages.get(key);
  if (chainages.size > 5000) chainages.clear();
  const s = state.site;
  let best = 0, bd = Infinity;
  for (let i = 0; i < s.centre.length; i++) {
    const dx = s.centre[i][0] - x, dy = s.centre[i][1] - y, d = dx * dx + dy * dy;
    if (d < bd) { bd = d; best = i; }
  }
  chainages.set(key, s.stations_m[best]);
  return s.stations_m[best];
}

function stationIndex(m) {
  const st = state.site.stations_m;
  let lo = 0, hi = st.length - 1;
  while (lo < hi) { const mid = (lo + hi) >> 1; if (st[mid] < m) lo = mid + 1; else hi = mid; }
  return lo;
}

// ---- the view: world metres to screen pixels ----------------------------------------

// `k` px a metre along x, `ky` along y: a tunnel is long and narrow, so its width may be
// drawn up to MAX_STRETCH times its length's scale to fill the pane's height (said on the
// map whenever it is), as a control room's schematic does.
const MAX_STRETCH = 6;
const view = { k: 5, ky: 5, cx: 0, cy: 0, w: 100, h: 100, follow: true, fittedAt: 0 };

function measure() {
  const box = $("map").getBoundingClientRect();
  view.w = Math.max(box.width, 1); view.h = Math.max(box.height, 1);
}
const sx = (x) => view.w / 2 + (x - view.cx) * view.k;
const sy = (y) => view.h / 2 - (y - view.cy) * view.ky;
const wx = (px) => view.cx + (px - view.w / 2) / view.k;
const wy = (py) => view.cy - (py - view.h / 2) / view.ky;
// A heading on screen, degrees clockwise, with the stretch applied.
const screenDeg = (yaw) => Math.atan2(-Math.sin(yaw) * view.ky, Math.cos(yaw) * view.k) * 180 / Math.PI;

// Look at the box [x0, x1] x [y0, y1] of the site, whole, as large as the pane allows.
function look(x0, x1, y0, y1) {
  measure();
  view.cx = (x0 + x1) / 2; view.cy = (y0 + y1) / 2;
  const fitY = view.h / Math.max(y1 - y0, 1);
  view.k = Math.min(view.w / Math.max(x1 - x0, 1), fitY, 60);
  view.ky = Math.max(view.k, Math.min(fitY, view.k * MAX_STRETCH));
  scheduleRender();
}

function wholeTunnel() {
  const s = state.site, pts = [...s.left_wall, ...s.right_wall];
  const xs = pts.map((p) => p[0]), ys = pts.map((p) => p[1]);
  view.follow = false;
  look(Math.min(...xs) - 5, Math.max(...xs) + 5, Math.min(...ys) - 4, Math.max(...ys) + 4);
}

// The incident's extent: live units and fires not out, 15 m around, at least 60 m of
// tunnel and its whole width.
function fitIncident() {
  const s = state.site;
  const pts = [];
  for (const u of state.units.values()) if (u.state && !u.lost) pts.push([u.state.pose.x, u.state.pose.y]);
  for (const f of state.fires.values()) if (f.state !== "out") pts.push([f.position.x, f.position.y]);
  if (!pts.length) { wholeTunnel(); view.follow = true; return; }
  let x0 = Math.min(...pts.map((p) => p[0])) - 15, x1 = Math.max(...pts.map((p) => p[0])) + 15;
  if (x1 - x0 < 60) { const c = (x0 + x1) / 2; x0 = c - 30; x1 = c + 30; }
  const wall = [...s.left_wall, ...s.right_wall].filter((p) => p[0] >= x0 && p[0] <= x1).map((p) => p[1]);
  const ys = wall.length ? wall : pts.map((p) => p[1]);
  look(x0, x1, Math.min(...ys) - 3, Math.max(...ys) + 3);
  view.follow = true;
  view.fittedAt = Date.now();
}

// While following, look again when something of the incident left the view (or every
// ten seconds), not at every update: a map that jumps cannot be read.
function follow() {
  if (!view.follow || !state.site) return;
  const out = (x, y) => sx(x) < 0 || sx(x) > view.w || sy(y) < 0 || sy(y) > view.h;
  const left = [...state.units.values()].some((u) => u.state && !u.lost && out(u.state.pose.x, u.state.pose.y))
    || [...state.fires.values()].some((f) => f.state !== "out" && out(f.position.x, f.position.y));
  if (left || Date.now() - view.fittedAt > 10000) fitIncident();
}

function setupPanZoom() {
  const svg = $("map");
  const zoomAt = (px, py, factor) => {
    const x = wx(px), y = wy(py);
    const k = Math.min(Math.max(view.k * factor, 0.05), 200);
    view.ky *= k / view.k; view.k = k;
    view.cx = x - (px - view.w / 2) / view.k; view.cy = y + (py - view.h / 2) / view.ky;
    view.follow = false;
    scheduleRender();
  };
  svg.addEventListener("wheel", (ev) => {
    ev.preventDefault();
    const box = svg.getBoundingClientRect();
    zoomAt(ev.clientX - box.left, ev.clientY - box.top, ev.deltaY > 0 ? 1 / 1.2 : 1.2);
  }, { passive: false });
  // One pointer pans, two pinch; a press that did not move is a click.
  const pointers = new Map();
  let moved = false, pinch = null;
  svg.addEventListener("pointerdown", (ev) => {
    pointers.set(ev.pointerId, { x: ev.clientX, y: ev.clientY });
    if (pointers.size === 1) moved = false;
    if (pointers.size === 2) { const [a, b] = [...pointers.values()]; pinch = { d: Math.hypot(a.x - b.x, a.y - b.y) }; }
  });
  svg.addEventListener("pointermove", (ev) => {
    const p = pointers.get(ev.pointerId);
    if (!p) return;
    const box = svg.getBoundingClientRect();
    if (pointers.size === 2 && pinch) {
      p.x = ev.clientX; p.y = ev.clientY;
      const [a, b] = [...pointers.values()];
      const d = Math.hypot(a.x - b.x, a.y - b.y);
      if (pinch.d > 0) zoomAt((a.x + b.x) / 2 - box.left, (a.y + b.y) / 2 - box.top, d / pinch.d);
      pinch.d = d; moved = true;
      return;
    }
    const dx = ev.clientX - p.x, dy = ev.clientY - p.y;
    if (!moved && Math.abs(dx) + Math.abs(dy) < 4) return;
    moved = true;
    view.cx -= dx / view.k; view.cy += dy / view.ky; view.follow = false;
    p.x = ev.clientX; p.y = ev.clientY;
    scheduleRender();
  });
  const up = (ev) => { pointers.delete(ev.pointerId); if (pointers.size < 2) pinch = null; };
  svg.addEventListener("pointerup", up);
  svg.addEventListener("pointercancel", up);
  svg.addEventListener("click", (ev) => { if (moved) { ev.stopPropagation(); moved = false; } }, true);
  $("overview").addEventListener("click", (ev) => {
    const box = $("overview").getBoundingClientRect();
    const [x0, x1] = overviewSpan();
    view.cx = x0 + (ev.clientX - box.left) / box.width * (x1 - x0);
    view.follow = false;
    scheduleRender();
  });
  $("fit-incident").addEventListener("click", fitIncident);
  $("fit-tunnel").addEventListener("click", wholeTunnel);
  window.addEventListener("resize", () => { if (state.site) { measure(); view.follow ? fitIncident() : scheduleRender(); } });
}

// ---- the site, drawn once ------------------------------------------------------------

function drawSite() {
  const s = state.site;
  $("scenario").textContent = `${s.scenario} (site ${s.site}, ${fmt(s.length_m, 0)} m)`;
  for (const id of ["heat", "zones", "air", "walls", "rails", "obstacles", "fires", "units", "tasks", "labels"]) $(id).replaceChildren();
  unitEls.clear(); fireEls.clear(); taskEls.clear();
  const pts = (list) => list.map((p) => `${p[0]},${p[1]}`).join(" ");
  for (const z of s.zones) {
    const poly = el("polygon", { class: "zone", points: pts(z.outline), "data-zone": z.id }, $("zones"));
    poly.addEventListener("click", () => selectZone(z.id));
    poly.appendChild(title(`zone ${z.id}: ${fmt(z.start_m, 0)} to ${fmt(z.end_m, 0)} m`));
  }
  el("polyline", { class: "wall", points: pts(s.left_wall) }, $("walls"));
  el("polyline", { class: "wall", points: pts(s.right_wall) }, $("walls"));
  el("polyline", { class: "centre", points: pts(s.centre) }, $("walls"));
  for (const r of s.rails) {
    el("polyline", { class: "rail", points: pts(r.line) }, $("rails"));
    for (const h of r.hose_points) el("circle", { class: "hose", cx: h[0], cy: h[1], r: 0.3 }, $("rails"));
  }
  for (const o of s.obstacles) el("polygon", { class: "obstacle", points: pts(o.corners) }, $("obstacles")).appendChild(title(o.name));
  const select = $("goal-zone");
  select.replaceChildren(...s.zones.map((z) => new Option(`${z.id} (${fmt(z.start_m, 0)}-${fmt(z.end_m, 0)} m)`, z.id)));
  select.onchange = () => selectZone(select.value);
  drawOverviewSite();
  measure();
  fitIncident();
}

function selectZone(id) {
  state.selectedZone = id;
  $("goal-zone").value = id;
  for (const p of document.querySelectorAll("polygon.zone")) p.classList.toggle("selected", p.dataset.zone === id);
  showTab("goal-pane");
}

// The goal a zone shows: the governing one, as the coordinator ranks them (the incident
// commander's above a sector commander's is not known here: the highest priority, which
// the list below spells out in full).
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
  for (const poly of document.querySelectorAll("polygon.zone")) {
    const goal = by.get(poly.dataset.zone);
    const kind = goal ? goal.goal.goal : "";
    poly.setAttribute("class", `zone ${kind}` + (state.selectedZone === poly.dataset.zone ? " selected" : ""));
    poly.dataset.goal = kind;
  }
  const list = $("goals");
  list.replaceChildren(...state.goals.map((g) => {
    const until = g.until != null ? `, until ${when(g.until, 0)}` : "";
    const li = html("li", { textContent: `${g.goal.zone}: ${g.goal.goal} p${g.goal.priority} by ${g.goal.issued_by} since ${when(g.since, 0)}${until} (${g.goal.id})` });
    li.dataset.zone = g.goal.zone; li.dataset.goal = g.goal.goal;
    return li;
  }));
  if (!state.goals.length) list.replaceChildren(html("li", { textContent: "none" }));
  drawOverviewSite();
  scheduleRender();
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
      const p = [offset(i, s.lateral_m[j]), offset(i + step, s.lateral_m[j]), offset(i + step, s.lateral_m[j + 1]), offset(i, s.lateral_m[j + 1])];
      el("polygon", { points: p.map((x) => `${x[0]},${x[1]}`).join(" "), fill: `rgba(255,${Math.round(160 - 120 * a)},0,${0.15 + 0.55 * a})` }, layer);
    }
  }
}

// ---- the overview strip: the whole tunnel, the view on it ----------------------------

function overviewSpan() {
  const xs = [...state.site.left_wall, ...state.site.right_wall].map((p) => p[0]);
  return [Math.min(...xs), Math.max(...xs)];
}

function drawOverviewSite() {
  const ov = $("overview"), s = state.site;
  if (!s) return;
  const [x0, x1] = overviewSpan();
  const ys = [...s.left_wall, ...s.right_wall].map((p) => p[1]);
  const y0 = Math.min(...ys), y1 = Math.max(...ys);
  // Stretched to the strip: the strip is for where along the tunnel, not for shapes.
  ov.setAttribute("viewBox", `${x0} ${-y1} ${x1 - x0} ${y1 - y0}`);
  ov.setAttribute("preserveAspectRatio", "none");
  ov.replaceChildren();
  const by = zoneGoals();
  for (const z of s.zones) {
    const g = by.get(z.id);
    el("polygon", { class: `zone ${g ? g.goal.goal : ""}`, points: z.outline.map((p) => `${p[0]},${-p[1]}`).join(" ") }, ov);
  }
  for (const w of [s.left_wall, s.right_wall]) el("polyline", { class: "ov-wall", points: w.map((p) => `${p[0]},${-p[1]}`).join(" "), "vector-effect": "non-scaling-stroke" }, ov);
  el("g", { id: "ov-items" }, ov);
  el("rect", { id: "ov-view", class: "view-box", "vector-effect": "non-scaling-stroke" }, ov);
}

function drawOverviewItems(units, fires) {
  const g = $("ov-items");
  if (!g) return;
  g.replaceChildren();
  const s = state.site, half = s.width_m / 2;
  for (const f of fires) {
    if (f.state === "out") continue;
    el("rect", { x: f.position.x - 1, y: -half, width: 2, height: s.width_m, fill: f.state === "suppressing" ? "#1890ff" : "#ff4d00" }, g);
  }
  for (const u of units) {
    el("rect", { x: u.x - 0.4, y: -u.y - 1, width: 0.8, height: 2, fill: u.lost ? "#ff4d4f" : u.kind === "monorail" ? "#b37feb" : "#52c41a" }, g);
  }
  const v = $("ov-view");
  v.setAttribute("x", wx(0)); v.setAttribute("width", view.w / view.k);
  v.setAttribute("y", -wy(0)); v.setAttribute("height", view.h / view.ky);
}

// ---- markers and labels, in screen pixels --------------------------------------------

const unitEls = new Map(), fireEls = new Map(), taskEls = new Map();
const fireClass = (state) => ({ tentative: "tentative", confirmed: "burning", assigned: "burning", suppressing: "suppressing", out: "out", lost: "tentative" }[state] || "burning");
const ACTIVE_PHASES = new Set(["travelling", "spraying"]);

function unitStatus(u, now) {
  if (u.lost) return "lost";
  if (!u.state) return "unheard";
  return now - (u.heard_ms - state.clockSkew) > STALE_MS ? "stale" : "fresh";
}

// What the map shows now: live, or a snapshot of the timeline.
function shownItems(now) {
  const snap = timeline.shown();
  if (snap) return snap;
  const units = [];
  for (const u of state.units.values()) {
    const s = u.state;
    if (!s) continue;
    const task = s.task && ACTIVE_PHASES.has(s.task.phase) ? s.task : null;
    units.push({ id: u.id, kind: s.kind, x: s.pose.x, y: s.pose.y, yaw: s.pose.yaw, status: unitStatus(u, now), lost: u.lost,
      autonomous: s.autonomous, fault: s.mode === "fault", task: task && { fire: task.fire, x: task.target.x, y: task.target.y } });
  }
  const fires = [...state.fires.values()].map((f) => ({ id: f.id, state: f.state, position: f.position, hrr_kw: f.state === "out" ? null : f.hrr_kw, assigned: f.assigned }));
  return { units, fires };
}

// Hundreds of units along kilometres: where CLUSTER_MIN or more markers would share a
// CLUSTER_PX stretch of the screen, they are drawn as one count instead, coloured by the
// worst of them (lost, then stale) and named in its tooltip; a click looks at that stretch
// closely enough to tell them apart. Their labels and task lines go with them. Returns the
// units still drawn one by one.
const CLUSTER_PX = 40, CLUSTER_MIN = 3;
function cluster(units) {
  const layer = $("clusters");
  layer.replaceChildren();
  // Runs along the screen's x: a unit joins a run whose first unit is under CLUSTER_PX to
  // its left and under CLUSTER_PX above or below it (a fixed grid would split a pile at
  // its lines). Both, not x alone: units abreast in two lanes are apart on the screen once
  // it looks closely, and a look is as close as the tunnel's width lets it (the x scale
  // never outgrows the y scale that fits the width), so three at work round one fire in
  // a pile-up stayed one count after the click that was to tell them apart.
  const runs = [];
  for (const u of [...units].sort((a, b) => sx(a.x) - sx(b.x))) {
    let run = null;
    for (let i = runs.length - 1; i >= 0 && sx(u.x) - sx(runs[i][0].x) < CLUSTER_PX; i--) {
      if (Math.abs(sy(u.y) - sy(runs[i][0].y)) < CLUSTER_PX) { run = runs[i]; break; }
    }
    if (run) run.push(u); else runs.push([u]);
  }
  const hidden = new Set();
  for (const us of runs) {
    if (us.length < CLUSTER_MIN) continue;
    for (const u of us) hidden.add(u.id);
    const worst = ["lost", "stale"].find((st) => us.some((u) => u.status === st)) || "fresh";
    const cx = us.reduce((a, u) => a + sx(u.x), 0) / us.length, cy = us.reduce((a, u) => a + sy(u.y), 0) / us.length;
    const g = el("g", { class: `cluster ${worst}`, "data-count": us.length }, layer);
    el("circle", { cx, cy, r: 13 }, g);
    el("text", { x: cx, y: cy + 4, "text-anchor": "middle" }, g).textContent = us.length;
    const ids = us.map((u) => u.id);
    g.appendChild(title(`${us.length} units: ${ids.slice(0, 30).join(", ")}${ids.length > 30 ? ", ..." : ""}; click to look closer`));
    g.addEventListener("click", () => {
      const xs = us.map((u) => u.x), ys = us.map((u) => u.y), half = state.site.width_m / 2;
      view.follow = false;
      look(Math.min(...xs) - 10, Math.max(...xs) + 10, Math.min(...ys) - half, Math.max(...ys) + half);
    });
  }
  for (const [id, g] of unitEls) g.setAttribute("visibility", hidden.has(id) ? "hidden" : "visible");
  for (const [id, l] of taskEls) l.setAttribute("visibility", hidden.has(id) ? "hidden" : "visible");
  return units.filter((u) => !hidden.has(u.id));
}

let renderQueued = false;
function scheduleRender() {
  if (renderQueued) return;
  renderQueued = true;
  requestAnimationFrame(() => { renderQueued = false; render(); });
}

function render() {
  if (!state.site) return;
  measure();
  follow();
  $("world").setAttribute("transform", `translate(${view.w / 2 - view.cx * view.k} ${view.h / 2 + view.cy * view.ky}) scale(${view.k} ${-view.ky})`);
  const now = Date.now();
  const { units, fires } = shownItems(now);
  const fireState = new Map(fires.map((f) => [f.id, f.state]));
  // Fires.
  const seenF = new Set();
  for (const f of fires) {
    seenF.add(f.id);
    let g = fireEls.get(f.id);
    if (!g) { g = el("g", { "data-fire": f.id }, $("fires")); el("circle", {}, g); g.appendChild(title("")); fireEls.set(f.id, g); }
    // Area proportional to the heat release (1 MW: 1 m radius), never under 7 px.
    const r = f.state === "out" ? 5 : Math.max(7, Math.sqrt((f.hrr_kw || 500) / 1000) * view.k);
    g.setAttribute("class", `fire ${fireClass(f.state)}`);
    g.dataset.state = f.state;
    const c = g.firstChild;
    c.setAttribute("cx", sx(f.position.x)); c.setAttribute("cy", sy(f.position.y)); c.setAttribute("r", r);
    g.dataset.r = r;
    g.lastChild.textContent = `${f.id}: ${f.state}${f.hrr_kw != null ? `, ${fmt(f.hrr_kw / 1000, 1)} MW` : ""}, units ${(f.assigned || []).join(", ") || "none"}`;
  }
  for (const [id, g] of fireEls) if (!seenF.has(id)) { g.remove(); fireEls.delete(id); }
  // Units and their task lines (only to a fire that still burns).
  const seenU = new Set();
  for (const u of units) {
    seenU.add(u.id);
    let g = unitEls.get(u.id);
    if (!g) {
      g = el("g", { "data-unit": u.id }, $("units"));
      el("path", { d: u.kind === "monorail" ? "M 9 0 L 0 7 L -9 0 L 0 -7 Z" : "M 11 0 L -7 7 L -7 -7 Z" }, g);
      g.appendChild(title(u.id));
      g.addEventListener("click", () => selectUnit(u.id));
      unitEls.set(u.id, g);
    }
    g.setAttribute("class", `unit ${u.kind} ${u.status}` + (u.autonomous ? " autonomous" : "") + (u.fault ? " fault" : "") + (state.selectedUnit === u.id ? " selected" : ""));
    g.dataset.status = u.status; g.dataset.x = u.x; g.dataset.y = u.y;
    g.setAttribute("transform", `translate(${sx(u.x)} ${sy(u.y)}) rotate(${screenDeg(u.yaw)})`);
    let line = taskEls.get(u.id);
    const fs = u.task && fireState.get(u.task.fire);
    if (u.task && fs && fs !== "out" && u.status !== "lost") {
      if (!line) { line = el("line", { class: "task", "data-unit": u.id }, $("tasks")); taskEls.set(u.id, line); }
      line.setAttribute("x1", sx(u.x)); line.setAttribute("y1", sy(u.y));
      line.setAttribute("x2", sx(u.task.x)); line.setAttribute("y2", sy(u.task.y));
    } else if (line) { line.remove(); taskEls.delete(u.id); }
  }
  for (const [id, g] of unitEls) if (!seenU.has(id)) { g.remove(); unitEls.delete(id); }
  for (const [id, l] of taskEls) if (!seenU.has(id)) { l.remove(); taskEls.delete(id); }
  placeLabels(cluster(units), fires, drawScale());
  drawOverviewItems(units, fires);
  const span = `${fmt(Math.max(0, chainageOf(wx(0), view.cy)), 0)} to ${fmt(chainageOf(wx(view.w), view.cy), 0)} m`;
  const stretch = view.ky / view.k;
  $("view-span").textContent = `showing ${span}` + (stretch > 1.05 ? `, width drawn \u00d7${fmt(stretch, 1)}` : "") +
    (view.follow ? ", following the incident" : "") +
    (window.ffStats.labels_hidden ? `, ${window.ffStats.labels_hidden} labels hidden: zoom in` : "");
}

// A chainage scale along the right-hand wall, on screen; the boxes its labels take.
function drawScale() {
  const g = $("scale"), s = state.site, boxes = [];
  g.replaceChildren();
  const step = [5, 10, 20, 50, 100, 200, 500, 1000, 2000].find((m) => m * view.k >= 80) || 5000;
  const half = s.width_m / 2;
  for (let m = 0; m <= s.length_m + 1e-6; m += step) {
    const i = stationIndex(m);
    const [x, y] = offset(i, -half);
    const px = sx(x), py = sy(y);
    if (px < -20 || px > view.w + 20 || py < -20 || py > view.h + 20) continue;
    el("line", { class: "tick", x1: px, y1: py, x2: px, y2: py + 8 }, g);
    const text = `${m} m`;
    el("text", { class: "tick-label", x: px, y: py + 21 }, g).textContent = text;
    boxes.push({ x: px - text.length * 4, y: py, w: text.length * 8, h: 24 });
  }
  return boxes;
}

// Labels: fires first (their state is what a commander looks for), then units, each at
// the first of its candidate places that overlaps no label placed before it; zone and
// portal names are placed first, where they belong. A grid of 64 px cells keeps the test
// near-linear for a thousand units.
function placeLabels(units, fires, taken) {
  const layer = $("labels");
  layer.replaceChildren();
  const cells = new Map(), CELL = 64;
  const keys = (b) => {
    const out = [];
    for (let i = Math.floor(b.x / CELL); i <= Math.floor((b.x + b.w) / CELL); i++)
      for (let j = Math.floor(b.y / CELL); j <= Math.floor((b.y + b.h) / CELL); j++) out.push(`${i},${j}`);
    return out;
  };
  const hits = (b) => keys(b).some((k) => (cells.get(k) || []).some((o) => b.x < o.x + o.w && o.x < b.x + b.w && b.y < o.y + o.h && o.y < b.y + b.h));
  const take = (b) => { for (const k of keys(b)) { if (!cells.has(k)) cells.set(k, []); cells.get(k).push(b); } };
  for (const b of taken) take(b);
  const charW = LABEL_FONT_PX * 0.62, lineH = LABEL_FONT_PX + 3;
  const onScreen = (x, y) => x >= -40 && x <= view.w + 40 && y >= -40 && y <= view.h + 40;
  const put = (text, cls, b, forId) => {
    const t = el("text", { class: `label ${cls}`, x: b.x + 1, y: b.y + LABEL_FONT_PX }, layer);
    t.textContent = text;
    if (forId) t.dataset.for = forId;
    return t;
  };
  // Zones' names and goals at the tunnel's left wall, portals at its ends.
  const by = zoneGoals(), s = state.site;
  for (const z of s.zones) {
    const g = by.get(z.id);
    const i = stationIndex((z.start_m + z.end_m) / 2);
    const [x, y] = offset(i, s.width_m / 2);
    const px = sx(x), py = sy(y) - 6;
    if (!onScreen(px, py)) continue;
    const text = g ? `${z.id}: ${g.goal.goal.toUpperCase()} (${g.goal.issued_by})` : z.id;
    const b = { x: px - text.length * charW / 2, y: py - lineH, w: text.length * charW + 2, h: lineH };
    if (hits(b)) continue;
    take(b);
    put(text, g ? "zone-goal" : "zone-name", b);
  }
  const ends = [[0, s.portals[0]], [s.length_m, s.portals[1]]];
  for (const [m, name] of ends) {
    const [x, y] = offset(stationIndex(m), 0);
    const px = sx(x), py = sy(y);
    if (!onScreen(px, py)) continue;
    const text = `${name} portal`.replace(/ portal portal$/, " portal");
    const w = text.length * charW + 2;
    const b = { x: m === 0 ? px - w - 8 : px + 8, y: py - lineH / 2, w, h: lineH };
    take(b);
    put(text, "portal", b);
  }
  const items = [];
  for (const f of fires) {
    const r = f.state === "out" ? 5 : Math.max(7, Math.sqrt((f.hrr_kw || 500) / 1000) * view.k);
    items.push({ id: f.id, text: f.state === "out" ? `${f.id} out` : `${f.id} ${f.hrr_kw != null ? `${fmt(f.hrr_kw / 1000, 1)} MW` : f.state}`, cls: `fire-label ${f.state === "out" ? "out" : ""}`, x: sx(f.position.x), y: sy(f.position.y), r, rank: f.state === "out" ? 2 : 0 });
  }
  for (const u of units) items.push({ id: u.id, text: u.id, cls: "unit-label", x: sx(u.x), y: sy(u.y), r: 11, rank: 1 });
  items.sort((a, b) => a.rank - b.rank);
  // Markers are obstacles too: a label must not hide a unit or a fire.
  for (const it of items) if (onScreen(it.x, it.y)) take({ x: it.x - it.r * 0.7, y: it.y - it.r * 0.7, w: it.r * 1.4, h: it.r * 1.4 });
  let hidden = 0;
  for (const it of items) {
    if (!onScreen(it.x, it.y)) continue;
    const w = it.text.length * charW + 2, h = lineH;
    let placed = null;
    for (const ring of [0, 1, 2]) {
      const d = it.r + 3 + ring * 16;
      const cands = [[d, -h / 2], [-d - w, -h / 2], [-w / 2, -d - h], [-w / 2, d], [d, -d - h], [-d - w, -d - h], [d, d], [-d - w, d]];
      for (const [dx, dy] of cands) {
        const b = { x: it.x + dx, y: it.y + dy, w, h };
        if (b.x < 0 || b.y < 0 || b.x + w > view.w || b.y + h > view.h || hits(b)) continue;
        placed = b; break;
      }
      if (placed) {
        if (ring > 0) el("line", { class: "leader", x1: it.x, y1: it.y, x2: placed.x + (placed.x > it.x ? 0 : w), y2: placed.y + h / 2 }, layer);
        break;
      }
    }
    if (!placed) { hidden++; continue; }
    take(placed);
    put(it.text, it.cls, placed, it.id);
  }
  window.ffStats.labels_hidden = hidden;
}

// ---- the side panes ------------------------------------------------------------------

const unitRows = new Map();

function doing(s) {
  if (!s) return "-";
  const task = s.task && ACTIVE_PHASES.has(s.task.phase) ? (s.task.phase === "spraying" ? ` spraying ${s.task.fire}` : ` to ${s.task.fire}`) : "";
  return s.mode + task + (s.autonomous ? " (alone)" : "") + (s.refused ? " REFUSED" : "");
}

// A task in the coordinator's words, its coordinates as chainage: "(80.0, -1.9)" -> "80 m".
const ordered = (text) => text ? text.replace(/\((-?\d+(?:\.\d+)?), (-?\d+(?:\.\d+)?)\)/g, (_, x, y) => `${fmt(chainageOf(Number(x), Number(y)), 0)} m`) : "-";

function unitRow(u, now) {
  let tr = unitRows.get(u.id);
  if (!tr) {
    tr = html("tr");
    tr.dataset.unit = u.id;
    for (let i = 0; i < 8; i++) tr.appendChild(html("td"));
    tr.addEventListener("click", () => selectUnit(u.id));
    unitRows.set(u.id, tr);
    $("units-body").appendChild(tr);
    unitTable.due = true;
  }
  const s = u.state, status = unitStatus(u, now), td = tr.children;
  tr.className = status + (state.selectedUnit === u.id ? " selected" : ""); tr.dataset.status = status;
  td[0].textContent = u.id;
  td[1].textContent = doing(s);
  td[2].textContent = ordered(u.ordered);
  // What a column sorts by where its text does not: the number behind it.
  td[3].dataset.sort = u.tank_pct ?? ""; td[4].dataset.sort = u.time_left_s ?? "";
  td[5].dataset.sort = s ? s.health : ""; td[6].dataset.sort = u.eta_s ?? "";
  td[7].dataset.sort = status === "lost" ? -1 : u.heard_ms ?? "";
  td[3].textContent = u.tank_pct != null ? `${fmt(u.tank_pct, 0)} %` : s ? (s.kind === "monorail" ? "main" : `${fmt(s.water_l, 0)} L`) : "-";
  td[3].className = u.tank_pct != null && u.tank_pct < 15 ? "low" : u.tank_pct != null && u.tank_pct < 35 ? "mid" : "";
  td[4].textContent = u.time_left_s != null ? dur(u.time_left_s) : "-";
  td[4].className = u.time_left_s != null && u.time_left_s < 60 ? "low" : "";
  td[5].textContent = s ? `${fmt(s.health * 100, 0)} %` : "-";
  td[5].className = s && s.health < 0.5 ? "low" : "";
  td[6].textContent = u.eta_s != null ? dur(u.eta_s) : "-";
  td[7].textContent = status === "lost" ? "LOST" : (u.heard_ms == null ? "never" : `${fmt((now - (u.heard_ms - state.clockSkew)) / 1000, 1)} s ago`);
  if (state.selectedUnit === u.id) unitDetail();
}

// The unit table: sorted by the column whose header was clicked (again: reversed; by
// unit at first), and filtered by the search box. Sorted at most twice a second, not at
// every update: a thousand units update hundreds of times a second.
const unitTable = { col: 0, desc: false, filter: "", due: false };
function sortKey(td) {
  const v = td.dataset.sort ?? td.textContent;
  return v === "" || v === "-" ? null : v;
}
function compareCells(a, b) {
  if (a == null || b == null) return (a == null) - (b == null); // blanks last
  const [x, y] = [Number(a), Number(b)];
  if (!Number.isNaN(x) && !Number.isNaN(y)) return x - y;
  return String(a).localeCompare(String(b), undefined, { numeric: true });
}
function sortUnits() {
  unitTable.due = false;
  const col = unitTable.col, sign = unitTable.desc ? -1 : 1, f = unitTable.filter.trim().toLowerCase();
  const rows = [...unitRows.values()];
  rows.sort((a, b) => {
    const [x, y] = [sortKey(a.children[col]), sortKey(b.children[col])];
    return (x == null || y == null ? compareCells(x, y) : sign * compareCells(x, y))
      || a.dataset.unit.localeCompare(b.dataset.unit, undefined, { numeric: true });
  });
  for (const tr of rows) tr.hidden = f !== "" && !tr.textContent.toLowerCase().includes(f);
  $("units-body").replaceChildren(...rows);
  $("unit-count").textContent = f ? `${rows.filter((r) => !r.hidden).length} of ${rows.length}` : `${rows.length}`;
  document.querySelectorAll("#units-table th").forEach((th, i) => {
    th.dataset.sorted = i === col ? (unitTable.desc ? "down" : "up") : "";
  });
}
function setupUnitTable() {
  document.querySelectorAll("#units-table th").forEach((th, i) => th.addEventListener("click", () => {
    unitTable.desc = unitTable.col === i ? !unitTable.desc : false;
    unitTable.col = i;
    sortUnits();
  }));
  $("unit-search").addEventListener("input", (ev) => { unitTable.filter = ev.target.value; sortUnits(); });
}

function selectUnit(id) {
  state.selectedUnit = state.selectedUnit === id ? null : id;
  for (const [k, tr] of unitRows) tr.classList.toggle("selected", k === state.selectedUnit);
  unitDetail();
  showTab("units-pane");
  scheduleRender();
}

function unitDetail() {
  const box = $("unit-detail"), u = state.units.get(state.selectedUnit);
  if (!u) { box.hidden = true; return; }
  box.hidden = false;
  const s = u.state;
  const rows = [
    ["unit", `${u.id} (${s ? s.kind : "not heard"})${u.lost ? ", LOST" : u.alive ? "" : ", no token"}`],
    ["doing", doing(s)],
    ["ordered", u.ordered ? ordered(u.ordered) : "nothing yet"],
    ["tank", u.tank_pct != null ? `${fmt(u.tank_pct, 0)} % (${fmt(s.water_l, 0)} L)` : s && s.kind === "monorail" ? "the tunnel's main" : "-"],
    ["flow", u.flow_l_s != null ? `${fmt(u.flow_l_s, 1)} L/s` : "-"],
    ["time left", u.time_left_s != null ? `${dur(u.time_left_s)} at this flow` : "not spraying"],
    ["health", s ? `${fmt(s.health * 100, 0)} %` : "-"],
    ["heat", s ? `${fmt(s.heat_flux_kw_m2, 1)} kW/m²` : "-"],
    ["speed", s ? `${fmt(s.speed, 1)} m/s` : "-"],
    ["at", s ? `chainage ${fmt(chainageOf(s.pose.x, s.pose.y), 0)} m` : "-"],
    ["arrives", u.eta_s != null ? `in ${dur(u.eta_s)} (straight line, current speed)` : "-"],
  ];
  const dl = html("dl");
  for (const [k, v] of rows) { html("dt", { textContent: k }, dl); html("dd", { textContent: v }, dl); }
  box.replaceChildren(dl);
}

function fireRows() {
  const fires = [...state.fires.values()].sort((a, b) => (a.state === "out") - (b.state === "out") || a.id.localeCompare(b.id, undefined, { numeric: true }));
  $("fires-body").replaceChildren(...fires.map((f) => {
    const tr = html("tr");
    tr.dataset.fire = f.id; tr.dataset.state = f.state;
    const out = f.state === "out";
    for (const v of [f.id, f.state, !out && f.hrr_kw != null ? `${fmt(f.hrr_kw / 1000, 1)} MW` : "-", `${fmt(chainageOf(f.position.x, f.position.y), 0)} m`, out ? "-" : f.assigned.join(" ") || "none"]) {
      html("td", { textContent: v }, tr);
    }
    if (out) tr.className = "stale";
    return tr;
  }));
}

// An alarm's state (ISA-18.2): active or returned to normal, acknowledged or not; closed
// once both returned and acknowledged. Active unacknowledged ones come first.
// ISA-18.2's states, with shelved beside them: a shelved alarm is off the banner and
// silent, whatever its cause does, until its time is up (the console brings it back).
function alarmState(a) {
  if (a.shelved) return "shelved";
  if (a.active) return a.acked_by == null ? "active-unacked" : "active-acked";
  return a.acked_by == null ? "returned-unacked" : "closed";
}
const ALARM_ORDER = { "active-unacked": 0, "returned-unacked": 1, "active-acked": 2, "shelved": 3, "closed": 4 };
const ALARM_WORDS = { "active-unacked": "ACTIVE", "active-acked": "active, acknowledged", "returned-unacked": "returned to normal, acknowledge to close", "closed": "closed" };
// Times on the shelf a commander picks from, minutes (the console takes up to a shift).
const SHELVE_MINUTES = [5, 15, 60, 240, 480];

function drawAlerts() {
  const alerts = [...state.alerts.values()].sort((a, b) =>
    ALARM_ORDER[alarmState(a)] - ALARM_ORDER[alarmState(b)] || a.priority - b.priority || b.id - a.id);
  const unacked = alerts.filter((a) => a.acked_by == null);
  $("alerts").replaceChildren(...alerts.map((a) => {
    const st = alarmState(a);
    const li = html("li", { className: `${st} p${a.priority}` });
    li.dataset.alert = a.id; li.dataset.kind = a.kind; li.dataset.priority = a.priority; li.dataset.state = st;
    if (a.unit) li.dataset.unit = a.unit;
    html("span", { className: "prio", textContent: `P${a.priority}` }, li);
    const times = a.count > 1 ? ` (x${a.count}, last ${when(a.last_t, 0)})` : "";
    const back = a.returned_t != null && !a.active ? `; back to normal at ${when(a.returned_t, 0)}` : "";
    const who = a.acked_by ? `; acknowledged by ${a.acked_by}` : "";
    const words = a.shelved
      ? `SHELVED by ${a.shelved.by} until ${new Date(a.shelved.until_ms).toLocaleTimeString([], { hour12: false })}: ${a.shelved.reason}; ${a.active ? "active" : "returned to normal"}`
      : ALARM_WORDS[st];
    li.append(` ${when(a.t, 0)} ${a.text}${times} [${words}${back}${who}] `);
    if (a.acked_by == null && !a.shelved) {
      const b = html("button", { textContent: "Acknowledge", disabled: !state.steers }, li);
      b.onclick = () => acknowledge([a.id]);
    }
    if (a.shelved) {
      const b = html("button", { textContent: "Unshelve", disabled: !state.steers, className: "unshelve" }, li);
      b.onclick = () => command("POST", `/api/alerts/${a.id}/unshelve`).then((r) => { if (!r.ok) $("ack").textContent = r.body.error; });
    } else if (st !== "closed") {
      const b = html("button", { textContent: "Shelve...", disabled: !state.steers, className: "shelve" }, li);
      b.onclick = () => { shelving.focused = true; shelveForm(li, a.id); };
      if (shelving.id === a.id) shelveForm(li, a.id);
    }
    return li;
  }));
  if (!alerts.length) $("alerts").replaceChildren(html("li", { textContent: "none" }));
  const typing = $("alerts").querySelector(".shelve-form input");
  if (typing && shelving.focused) refocus(typing);
  $("alerts-open").textContent = unacked.length ? `(${unacked.length})` : "";
  $("ack-all").disabled = !state.steers || !unacked.length;
  $("ack-all").textContent = unacked.length > 1 ? `Acknowledge all ${unacked.length}` : "Acknowledge all";
  banner();
  annunciate();
}

// The form a "Shelve..." opens under its alarm: why, and for how long. The list is drawn
// again at every change of any alarm, so what the commander has typed is kept here and
// the form drawn again with it.
const shelving = { id: null, reason: "", minutes: SHELVE_MINUTES[1], focused: false };
function shelveForm(li, id) {
  if (li.querySelector("form")) return;
  shelving.id = id;
  const f = html("form", { className: "shelve-form" }, li);
  const reason = html("input", { type: "text", placeholder: "why (required)", maxLength: 200, required: true, name: "reason", value: shelving.reason }, f);
  reason.oninput = () => { shelving.reason = reason.value; };
  reason.onfocus = () => { shelving.focused = true; };
  reason.onblur = () => { shelving.focused = false; };
  const minutes = html("select", { name: "minutes" }, f);
  for (const m of SHELVE_MINUTES) minutes.appendChild(new Option(m < 60 ? `${m} min` : `${m / 60} h`, m));
  minutes.value = shelving.minutes;
  minutes.onchange = () => { shelving.minutes = Number(minutes.value); };
  html("button", { type: "submit", textContent: "Shelve" }, f);
  const cancel = html("button", { type: "button", textContent: "Cancel" }, f);
  cancel.onclick = () => { shelving.id = null; shelving.reason = ""; f.remove(); };
  f.onsubmit = async (ev) => {
    ev.preventDefault();
    const r = await command("POST", `/api/alerts/${id}/shelve`, { reason: reason.value, minutes: Number(minutes.value) });
    if (!r.ok) { $("ack").textContent = r.body.error; return; }
    shelving.id = null; shelving.reason = ""; shelving.focused = false;
  };
  if (li.isConnected && shelving.focused) refocus(reason);
}
function refocus(input) {
  input.focus();
  input.setSelectionRange(input.value.length, input.value.length);
}

async function acknowledge(ids) {
  for (const id of ids) {
    const r = await command("POST", `/api/alerts/${id}/ack`);
    if (!r.ok) { $("ack").textContent = r.body.error; break; }
  }
}

// ---- annunciation: P1 alarms sound until acknowledged, and raise a notification ------
// The sound is the page's own (Web Audio: two tones, again every two seconds while any
// active P1 alarm is unacknowledged), so no file to load and nothing to autoplay: a
// browser lets a page sound only after a click on it, which logging in is; until then the
// button says so. Muting is per page and shows on the button. A notification goes up for
// each new P1 alarm where the commander allowed them (asked at login).
const audio = { context: null, muted: sessionStorage.getItem("ff-muted") === "1", playing: false, timer: null, notified: new Set() };
window.ffAudio = audio;

function unlockAudio() {
  if (!audio.context) audio.context = new AudioContext();
  if (audio.context.state === "suspended") audio.context.resume();
  if (window.Notification && Notification.permission === "default") Notification.requestPermission();
  annunciate();
}

function tone(at, hz) {
  const c = audio.context, o = c.createOscillator(), g = c.createGain();
  o.frequency.value = hz; o.type = "square";
  g.gain.setValueAtTime(0.0001, at);
  g.gain.exponentialRampToValueAtTime(0.2, at + 0.02);
  g.gain.exponentialRampToValueAtTime(0.0001, at + 0.25);
  o.connect(g).connect(c.destination);
  o.start(at); o.stop(at + 0.3);
}

function annunciate() {
  const p1 = [...state.alerts.values()].filter((a) => a.priority === 1 && alarmState(a) === "active-unacked");
  for (const a of p1) {
    if (audio.notified.has(a.id)) continue;
    audio.notified.add(a.id);
    if (window.Notification && Notification.permission === "granted") {
      new Notification(`P1: ${a.text}`, { tag: `ff-alarm-${a.id}`, requireInteraction: true });
    }
  }
  const sound = p1.length > 0 && !audio.muted && audio.context && audio.context.state === "running";
  if (sound && !audio.timer) {
    const ring = () => { const t = audio.context.currentTime; tone(t, 880); tone(t + 0.35, 660); };
    ring();
    audio.timer = setInterval(ring, 2000);
  } else if (!sound && audio.timer) {
    clearInterval(audio.timer); audio.timer = null;
  }
  audio.playing = !!audio.timer;
  const b = $("mute");
  b.textContent = audio.muted ? "sound: MUTED" : !audio.context ? "sound: off until a click" : audio.playing ? "sound: ALARM" : "sound: on";
  b.className = "badge" + (audio.muted ? " warn" : audio.playing ? " bad" : "");
}

// The banner above everything: the console's link to the site first, then the most
// urgent active alarm nobody acknowledged. An alarm whose cause ended leaves it at once.
function banner() {
  const b = $("banner");
  if (state.link === false) {
    b.className = ""; b.hidden = false;
    b.textContent = "SITE LOST: the console has no link to the site's router. Units are not known to be lost; what is shown is as last heard.";
    return;
  }
  const open = [...state.alerts.values()].filter((a) => alarmState(a) === "active-unacked").sort((a, c) => a.priority - c.priority || c.id - a.id);
  if (!open.length) { b.hidden = true; return; }
  b.hidden = false;
  b.className = open[0].priority > 1 ? "p2" : "";
  b.textContent = `P${open[0].priority}: ${open[0].text}` + (open.length > 1 ? ` (and ${open.length - 1} more alerts)` : "");
}

const KINDS = {
  assign: /assign|backup|reserve|relie|send |sent |search|stage|standby|adopt/i,
  goal: /goal|zone|keep-out|evacuate|withdraw|contain|monitor/i,
  unit: /lost|trapped|cannot|doubt|refus|silent|witness/i,
  fire: /fire f|\bf\d+\b|confirm|extinguish|\bout\b|merge/i,
};

function drawDecisions() {
  const text = $("decision-text").value.trim().toLowerCase();
  const kind = KINDS[$("decision-kind").value];
  const at = timeline.at();
  const lines = [...state.decisions.values()]
    .filter((l) => (!text || l.text.toLowerCase().includes(text)) && (!kind || kind.test(l.text)))
    .sort((a, b) => b.t - a.t || b.id - a.id)
    .slice(0, 200);
  $("decisions").replaceChildren(...lines.map((l) => {
    const li = html("li", { className: at != null && l.first_t > at ? "future" : "" });
    li.dataset.id = l.id; li.dataset.count = l.count;
    li.append(l.count > 1 ? `${when(l.first_t, 1)} to ${when(l.t, 1)} ` : `${when(l.t, 1)} `);
    html("span", { className: "text", textContent: l.text }, li);
    if (l.count > 1) html("b", { className: "count", textContent: `\u00d7${l.count}` }, li);
    return li;
  }));
}

// ---- the tunnel's own senses: DTS profile, alarms, ventilation, the SCADA link --------

function drawInfra() {
  const v = state.infra, badge = $("scada");
  $("infra-none").hidden = !!v; $("infra-body").hidden = !v; badge.hidden = !v;
  if (!v) return;
  const up = v.link_up === true;
  badge.textContent = up ? "SCADA live" : "SCADA STALE";
  badge.className = "badge " + (up ? "ok" : "bad");
  const since = v.last_ok != null ? ` (last good read t = ${fmt(v.last_ok, 1)} s)` : "";
  $("infra-link").textContent = up ? "Link to the tunnel's SCADA: live." : `Link to the tunnel's SCADA: DOWN, readings stale${since}: ${v.problem}`;
  const svg = $("dts-profile");
  svg.replaceChildren();
  const zs = v.zones;
  if (zs.length) {
    const end = Math.max(...zs.map((z) => z.end_m)), top = Math.max(100, ...zs.map((z) => z.max_c));
    svg.setAttribute("viewBox", `0 0 ${end} 100`);
    for (const z of zs) {
      const h = 100 * Math.max(0, z.max_c) / top;
      const r = el("rect", { x: z.start_m, y: 100 - h, width: Math.max(0.1, z.end_m - z.start_m) * 0.9, height: h, class: "dts" + (z.alarm ? " alarm" : "") + (z.stale ? " stale" : "") }, svg);
      r.appendChild(title(`${fmt(z.start_m, 0)}-${fmt(z.end_m, 0)} m: ${fmt(z.max_c, 1)} °C${z.alarm ? ", ALARM" : ""}${z.stale ? `, stale (read t = ${fmt(z.t, 1)} s)` : ""}`));
    }
    $("dts-scale").textContent = `0 to ${fmt(top, 0)} °C, chainage 0 to ${fmt(end, 0)} m`;
  }
  // Zones in alarm side by side are one stretch: a fire heats a run of 10 m zones.
  const ranges = [];
  for (const z of zs.filter((z) => z.alarm).sort((a, b) => a.start_m - b.start_m)) {
    const last = ranges[ranges.length - 1];
    if (last && z.start_m <= last.end_m + 0.01) {
      last.end_m = z.end_m; last.to = z.zone; last.max_c = Math.max(last.max_c, z.max_c); last.stale ||= z.stale;
    } else ranges.push({ from: z.zone, to: z.zone, start_m: z.start_m, end_m: z.end_m, max_c: z.max_c, stale: z.stale });
  }
  $("dts-alarms").replaceChildren(...(ranges.length ? ranges.map((r) => html("li", {
    textContent: `${r.from === r.to ? `zone ${r.from}` : `zones ${r.from}-${r.to}`}: ${fmt(r.start_m, 0)}-${fmt(r.end_m, 0)} m, up to ${fmt(r.max_c, 1)} °C${r.stale ? " (stale)" : ""}`,
  })) : [html("li", { textContent: "none" })]));
  drawAir();
  const w = v.vent;
  if (!w) { $("vent").textContent = "-"; return; }
  const fans = {};
  for (const f of w.fans) fans[f] = (fans[f] || 0) + 1;
  $("vent").textContent = `${airWords(w)}; fans: ${Object.entries(fans).map(([k, n]) => `${n} ${k}`).join(", ") || "none"}${w.stale ? ` (stale, read t = ${fmt(w.t, 1)} s)` : ""}`;
}

// Air slower than this is still, m/s.
const STILL_AIR_M_S = 0.05;
function airWords(w) {
  const portals = state.site ? state.site.portals : ["start", "end"];
  if (Math.abs(w.air_m_s) < STILL_AIR_M_S) return "air still";
  return `air flows towards ${w.air_m_s > 0 ? portals[1] : portals[0]} at ${fmt(Math.abs(w.air_m_s), 1)} m/s`;
}

// ---- the tunnel's air on the map: the DTS as a heat strip, the airflow, the fans, and
// the smoke side of every fire that burns (downstream of it, to the portal the air leaves
// by: in a longitudinally ventilated bore that is where its smoke goes) --------------------

// The floor between chainages `a` and `b`, from `d0` to `d1` metres left of the centreline.
function floorBand(a, b, d0, d1) {
  const last = state.site.stations_m.length - 1;
  const i0 = Math.min(stationIndex(Math.min(a, b)), last - 1), i1 = Math.max(stationIndex(Math.max(a, b)), i0 + 1);
  const pts = [];
  for (let i = i0; i <= i1; i++) pts.push(offset(i, d0));
  for (let i = i1; i >= i0; i--) pts.push(offset(i, d1));
  return pts.map((p) => `${p[0]},${p[1]}`).join(" ");
}
// The DTS strip's colour: yellow at DTS_COOL_C, red from DTS_HOT_C up, more opaque hotter;
// a zone at the tunnel's own temperature all but clear, so that heat stands out.
const DTS_COOL_C = 40, DTS_HOT_C = 300;
function dtsColour(c) {
  const f = Math.max(0, Math.min(1, (c - DTS_COOL_C) / (DTS_HOT_C - DTS_COOL_C)));
  const alpha = c < DTS_COOL_C ? 0.08 : 0.3 + 0.55 * f;
  return `hsla(${Math.round(60 - 60 * f)}, 100%, 50%, ${alpha.toFixed(2)})`;
}

function drawAir() {
  const g = $("air"), s = state.site, v = state.infra;
  g.replaceChildren();
  $("air-legend").hidden = !v;
  if (!s || !v) return;
  const q = s.width_m / 8;
  for (const z of v.zones) {
    const p = el("polygon", { class: "dts-strip" + (z.alarm ? " alarm" : "") + (z.stale ? " stale" : ""), points: floorBand(z.start_m, z.end_m, q, -q), "data-zone": z.zone }, g);
    if (!z.stale) p.style.fill = dtsColour(z.max_c);
    p.appendChild(title(`DTS zone ${z.zone}, ${fmt(z.start_m, 0)}-${fmt(z.end_m, 0)} m: ${fmt(z.max_c, 1)} °C${z.alarm ? ", ALARM" : ""}${z.stale ? `, stale (read t = ${fmt(z.t, 1)} s)` : ""}`));
  }
  const w = v.vent;
  $("air-legend-text").textContent = w ? airWords(w) + (w.stale ? " (stale)" : "") : "not read";
  if (!w) return;
  const dir = Math.sign(w.air_m_s), moving = Math.abs(w.air_m_s) >= STILL_AIR_M_S;
  const stale = w.stale ? " stale" : "";
  if (moving) {
    for (const f of state.fires.values()) {
      if (f.state === "out" || f.state === "lost") continue;
      const at = chainageOf(f.position.x, f.position.y), to = dir > 0 ? s.length_m : 0;
      el("polygon", { class: "smoke" + stale, points: floorBand(at, to, s.width_m / 2, -s.width_m / 2), "data-fire": f.id }, g)
        .appendChild(title(`${f.id}'s smoke side: ${fmt(Math.min(at, to), 0)}-${fmt(Math.max(at, to), 0)} m, downstream in the air`));
    }
    // A chevron every stretch along the centreline, pointing where the air goes.
    const every = Math.max(20, s.length_m / 40), h = s.width_m / 6;
    for (let m = every / 2; m < s.length_m; m += every) {
      const [tip, back] = [stationIndex(m + dir * 1.5), stationIndex(m - dir * 1.5)];
      const pts = [offset(back, h), offset(tip, 0), offset(back, -h)];
      el("polyline", { class: "air-arrow" + stale, points: pts.map((p) => `${p[0]},${p[1]}`).join(" ") }, g);
    }
  }
  s.fans.forEach((f, k) => {
    const running = w.fans[k] || "off";
    const fan = el("g", { class: `fan ${running}${stale}`, "data-fan": f.name }, g);
    el("polygon", { points: floorBand(f.chainage_m - 1, f.chainage_m + 1, 2 * q, -2 * q) }, fan);
    fan.appendChild(title(`jet fan ${f.name} at ${fmt(f.chainage_m, 0)} m: ${running}${w.stale ? " (stale)" : ""}`));
  });
}

// Site time as people read it: a simulated site's clock counts seconds from the start
// (t = 12.3 s), a real site's is the hosts' clock, Unix time, shown as the time of day.
const UNIX_T = 1e9;
function when(t, digits) {
  if (t >= UNIX_T) return new Date(t * 1000).toLocaleTimeString([], { hour12: false });
  return `t=${fmt(t, digits)} s`;
}

function drawHeader() {
  const at = timeline.at();
  $("clock").textContent = at != null ? `${when(at, 1)} (timeline; live ${when(state.t, 1)})` : when(state.t, 1);
  const c = $("coordinator");
  c.textContent = state.coordinator === true ? "coordinator in charge" : state.coordinator === false ? "NO COORDINATOR" : "coordinator ?";
  c.className = "badge " + (state.coordinator === true ? "ok" : state.coordinator === false ? "bad" : "");
  // A site without a standby is shown so plainly, not as a fault: the alarm says when one went.
  const s = $("standbys");
  s.textContent = state.standbys == null ? "standby ?" : state.standbys === 0 ? "no standby" : `${state.standbys} standby`;
  s.className = "badge " + (state.standbys > 0 ? "ok" : "");
  const l = $("site-link");
  l.textContent = state.link === true ? "site linked" : state.link === false ? "SITE LOST" : "site ?";
  l.className = "badge " + (state.link === true ? "ok" : state.link === false ? "bad" : "");
}

function showTab(id) {
  for (const b of document.querySelectorAll("#tabs button")) b.classList.toggle("on", b.dataset.tab === id);
  for (const p of document.querySelectorAll("aside .pane")) p.classList.toggle("on", p.id === id);
}

// ---- the timeline --------------------------------------------------------------------

const timeline = {
  snaps: [], scrub: null,
  // A snapshot a second of site time: where every unit and fire was.
  record() {
    const last = this.snaps[this.snaps.length - 1];
    if (last && state.t - last.t < 1) return;
    const snap = shownLive();
    snap.t = state.t;
    this.snaps.push(snap);
    if (this.snaps.length > MAX_SNAPSHOTS) {
      // Thin the older half to one in two: the whole incident stays, coarser further back.
      const half = this.snaps.length >> 1;
      this.snaps = this.snaps.slice(0, half).filter((_, i) => i % 2 === 0).concat(this.snaps.slice(half));
    }
    const r = $("timeline");
    r.min = this.snaps[0].t; r.max = state.t;
    if (this.scrub == null) r.value = state.t;
  },
  // The console's own timeline from before this page was opened (or reloaded): its
  // snapshots older than the page's first are put in front of them.
  async load() {
    let r;
    try { r = await fetch("/api/history", { credentials: "same-origin" }); } catch { return; }
    if (!r.ok) return;
    const first = this.snaps.length ? this.snaps[0].t : Infinity;
    const older = (await r.json()).filter((s) => s.t < first).map(fromHistory);
    if (!older.length) return;
    this.snaps = older.concat(this.snaps);
    const range = $("timeline");
    range.min = this.snaps[0].t;
    if (this.scrub == null) range.value = state.t;
    window.ffStats.historyLoaded = older.length;
  },
  at() { return this.scrub; },
  shown() {
    if (this.scrub == null) return null;
    let best = null;
    for (const s of this.snaps) { if (s.t <= this.scrub) best = s; else break; }
    return best || this.snaps[0] || null;
  },
  set(t) {
    this.scrub = t >= state.t - 0.5 ? null : t;
    $("timeline-t").textContent = this.scrub == null ? "live" : `t = ${fmt(this.scrub, 1)} s`;
    $("timeline-live").disabled = this.scrub == null;
    drawHeader(); drawDecisions(); scheduleRender();
  },
};

// A snapshot of the console's timeline (`/api/history`) as the page draws one.
function fromHistory(s) {
  return {
    t: s.t,
    units: s.units.map((u) => ({ id: u.id, kind: u.kind, x: u.x, y: u.y, yaw: u.yaw, status: u.lost ? "lost" : "fresh",
      lost: u.lost, autonomous: u.autonomous, fault: u.fault, task: u.task || null })),
    fires: s.fires.map((f) => ({ id: f.id, state: f.state, position: f.position, hrr_kw: f.hrr_kw ?? null, assigned: f.assigned })),
  };
}

function shownLive() {
  const scrub = timeline.scrub;
  timeline.scrub = null;
  const s = shownItems(Date.now());
  timeline.scrub = scrub;
  return s;
}

function setupTimeline() {
  $("timeline").addEventListener("input", (ev) => timeline.set(Number(ev.target.value)));
  $("timeline-live").addEventListener("click", () => { $("timeline").value = state.t; timeline.set(state.t); });
  $("decision-text").addEventListener("input", drawDecisions);
  $("decision-kind").addEventListener("change", drawDecisions);
  for (const b of document.querySelectorAll("#tabs button")) b.addEventListener("click", () => showTab(b.dataset.tab));
  $("ack-all").addEventListener("click", () => acknowledge([...state.alerts.values()].filter((a) => a.acked_by == null).map((a) => a.id)));
}

// ---- applying the stream -------------------------------------------------------------

function applyIncident(inc) {
  state.seq = inc.seq; state.t = inc.t; state.coordinator = inc.coordinator; state.standbys = inc.standbys; state.link = inc.link;
  if (!state.site || state.site.stations_m.length !== inc.site.stations_m.length || state.site.scenario !== inc.site.scenario) {
    state.site = inc.site; drawSite();
  }
  state.units = new Map(inc.units.map((u) => [u.id, u]));
  state.fires = new Map(inc.fires.map((f) => [f.id, f]));
  state.goals = inc.goals; state.alerts = new Map(inc.alerts.map((a) => [a.id, a]));
  state.decisions = new Map(inc.decisions.map((l) => [l.id, l]));
  state.heat = inc.heat;
  state.infra = inc.infra;
  unitRows.clear(); $("units-body").replaceChildren();
  const now = Date.now();
  for (const u of state.units.values()) unitRow(u, now);
  sortUnits();
  fireRows(); drawGoals(); drawHeat(); drawAlerts(); drawDecisions(); drawHeader(); drawInfra();
  timeline.record();
  timeline.load();
  fitIncident();
  window.ffStats.incidents++;
}

function applyDelta(d) {
  if (d.seq <= state.seq) return;
  state.seq = d.seq; state.t = d.t;
  if (d.coordinator != null) state.coordinator = d.coordinator;
  if (d.standbys != null) state.standbys = d.standbys;
  if (d.link != null) { state.link = d.link; banner(); }
  const now = Date.now();
  const heard = [];
  for (const u of d.units || []) {
    state.units.set(u.id, u); unitRow(u, now);
    if (u.heard_ms != null) heard.push(u.heard_ms);
  }
  // A move: the pose and what follows from it, on top of the unit the page holds.
  for (const m of d.moves || []) {
    const u = state.units.get(m.id);
    if (!u || !u.state) continue;
    const s = u.state;
    s.t = m.t; s.pose.x = m.x; s.pose.y = m.y; s.pose.yaw = m.yaw; s.speed = m.speed;
    s.water_l = m.water_l; s.heat_flux_kw_m2 = m.heat;
    u.heard_ms = m.heard_ms; u.tank_pct = m.tank_pct; u.time_left_s = m.time_left_s; u.eta_s = m.eta_s;
    unitRow(u, now);
    heard.push(m.heard_ms);
  }
  if (d.fires || d.fires_gone) {
    for (const f of d.fires || []) state.fires.set(f.id, f);
    for (const id of d.fires_gone || []) state.fires.delete(id);
    fireRows(); drawAir();
  }
  if (d.goals) { state.goals = d.goals; drawGoals(); }
  if (d.alerts) { for (const a of d.alerts) state.alerts.set(a.id, a); drawAlerts(); }
  if (d.heat) { state.heat = d.heat; drawHeat(); }
  if (d.infra) { state.infra = d.infra; drawInfra(); }
  if (d.decisions) { for (const l of d.decisions) state.decisions.set(l.id, l); drawDecisions(); }
  drawHeader();
  timeline.record();
  scheduleRender();
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
// The console beats every second when it has nothing else to say: a page that heard
// nothing for 3 s says its console is gone, whatever the browser thinks of the connection.
let heardAt = 0;
const SILENT_MS = 3000;
function connect() {
  if (source) source.close();
  const es = new EventSource("/api/stream");
  source = es;
  const heard = () => { heardAt = Date.now(); };
  es.addEventListener("incident", (ev) => { heard(); applyIncident(JSON.parse(ev.data)); link(true); });
  es.addEventListener("delta", (ev) => { heard(); applyDelta(JSON.parse(ev.data)); });
  es.addEventListener("beat", heard);
  es.onerror = () => link(false, es.readyState === EventSource.CLOSED && !state.me);
}
setInterval(() => {
  if (heardAt && source && Date.now() - heardAt > SILENT_MS) {
    const l = $("link");
    if (l.textContent === "live") link(false, false);
  }
  if (heardAt && Date.now() - heardAt <= SILENT_MS && $("link").textContent === "NO LINK to the console") link(true);
}, 500);

function link(up, loginNeeded) {
  const l = $("link");
  l.textContent = up ? "live" : loginNeeded ? "log in to see the incident" : "NO LINK to the console";
  l.className = "badge " + (up ? "ok" : "bad");
}

// Ages every unit on this page's clock, and sorts the table again.
setInterval(() => {
  const now = Date.now();
  for (const u of state.units.values()) unitRow(u, now);
  if (unitTable.due || unitTable.col !== 0 || unitTable.filter) sortUnits();
  scheduleRender();
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

// What a goal's preview says it would do to the fleet, in words; "" if nothing.
function previewHarm(p) {
  const said = [];
  if (p.trapped.length) said.push(`trap ${p.trapped.map((x) => x.unit).join(", ")} (they would hold where they are, inside the zone)`);
  if (p.stranded.length) said.push(`strand ${p.stranded.map((x) => `fire ${x.fire}`).join(", ")} (no unit could reach or attack it)`);
  return said.join(" and ");
}

async function issueGoal(form) {
  const ack = $("ack");
  ack.className = ""; ack.textContent = `issuing ${form.goal} on ${form.zone}...`;
  const r = await command("POST", "/api/goals", form);
  if (r.body.accepted === true) { ack.className = "accepted"; ack.textContent = `accepted: ${r.body.id}: ${r.body.reason}`; }
  else if (r.body.accepted === false) { ack.className = "rejected"; ack.textContent = `rejected: your goal ${r.body.id}: ${r.body.reason}`; }
  else { ack.className = "rejected"; ack.textContent = `not issued: ${r.body.error}`; }
}

function setupCommands() {
  // Any click on the page lets it sound; the mute button toggles this page's sound.
  document.addEventListener("pointerdown", unlockAudio, { once: true });
  $("mute").addEventListener("click", () => {
    audio.muted = !audio.muted;
    sessionStorage.setItem("ff-muted", audio.muted ? "1" : "0");
    unlockAudio();
  });
  $("login").addEventListener("submit", async (ev) => {
    unlockAudio();
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
    const minutes = $("goal-expires").value;
    if (minutes !== "") form.expires_s = Number(minutes) * 60;
    const ack = $("ack");
    ack.className = ""; ack.textContent = `checking what ${form.goal} on ${form.zone} would do...`;
    // What it would do first (the coordinator works it out on the incident as it is): a
    // goal that strands a fire or traps a unit is issued only when the commander says so.
    const p = await command("POST", "/api/goals/preview", form);
    const harm = p.ok && p.body.ack.accepted ? previewHarm(p.body) : "";
    if (harm) {
      ack.textContent = "";
      const box = $("preview");
      box.dataset.trapped = p.body.trapped.map((x) => x.unit).join(" ");
      box.dataset.stranded = p.body.stranded.map((x) => x.fire).join(" ");
      $("preview-text").textContent = `${form.goal} on ${form.zone} would ${harm}. Issue it anyway?`;
      box.hidden = false;
      $("preview-confirm").onclick = () => { box.hidden = true; issueGoal(form); };
      $("preview-cancel").onclick = () => { box.hidden = true; ack.className = ""; ack.textContent = `not issued: ${form.goal} on ${form.zone}`; };
      return;
    }
    issueGoal(form);
  });
  $("goal-clear").addEventListener("click", async () => {
    const zone = $("goal-zone").value;
    const r = await command("DELETE", `/api/goals/${encodeURIComponent(zone)}`);
    $("ack").className = r.ok ? "accepted" : "rejected";
    $("ack").textContent = r.ok ? `cleared your goals on ${zone}` : `not cleared: ${r.body.error}`;
  });
}

setupPanZoom();
setupTimeline();
setupUnitTable();
setupCommands();
command("GET", "/api/me").then((r) => { loggedIn(r.ok ? r.body.name : null, r.ok ? r.body.role : null); connect(); });
