// acphys live map: terrain of the service's landblocks and its movers, live (server-sent events).
// Coordinates: global metres, x = landblock column * 192 + local x, y likewise; north is up.
"use strict";

(function () {
  const LANDBLOCK_M = 192;
  const STALE_S = 30;
  const TRAIL = 60;               // points of trail kept per mover
  const COLOURS = { walkable: "#18c018", steep: "#ff8c00", air: "#1e5aff", stale: "#999999" };

  const canvas = document.getElementById("map");
  const ctx = canvas.getContext("2d");
  const statusEl = document.getElementById("status");
  const countEl = document.getElementById("mover-count");
  const listEl = document.getElementById("movers");
  const stateEl = document.getElementById("state");
  const selectedEl = document.getElementById("selected");

  const view = { cx: 0, cy: 0, scale: 1, fitted: false };   // scale: pixels per metre
  const terrain = new Map();   // "A9B4" -> {x0, y0, image (canvas) or null}
  const movers = new Map();    // id hex -> {state, x, y, trail: [[x, y], ...], updates}
  let selected = null;
  let info = null;
  let updates = 0;
  let dirty = true;

  function contactClass(st) {
    if ((Date.now() / 1000 - st.received) > STALE_S) return "stale";
    return st.on_walkable ? "walkable" : st.contact ? "steep" : "air";
  }

  function globalXY(st) {
    const lb = st.landblock;
    return [(lb >> 8) * LANDBLOCK_M + st.position.origin[0], (lb & 0xff) * LANDBLOCK_M + st.position.origin[1]];
  }

  // -- terrain -------------------------------------------------------------------------------
  function heightColour(t) {   // t in 0..1: green lowlands, brown hills, light tops
    const stops = [[0, [52, 120, 60]], [0.35, [118, 160, 74]], [0.6, [168, 140, 88]], [0.85, [150, 120, 100]], [1, [245, 245, 240]]];
    for (let i = 1; i < stops.length; i++) {
      if (t <= stops[i][0]) {
        const [t0, c0] = stops[i - 1], [t1, c1] = stops[i];
        const f = (t - t0) / (t1 - t0);
        return c0.map((c, k) => c + (c1[k] - c) * f);
      }
    }
    return stops[stops.length - 1][1];
  }

  function terrainImage(grid, lo, hi) {
    const n = grid.size, img = document.createElement("canvas");
    img.width = n; img.height = n;
    const g = img.getContext("2d"), data = g.createImageData(n, n);
    const h = (i, j) => grid.heights[Math.min(n - 1, Math.max(0, j)) * n + Math.min(n - 1, Math.max(0, i))];
    for (let j = 0; j < n; j++) {
      for (let i = 0; i < n; i++) {
        const z = h(i, j);
        const dzdx = (h(i + 1, j) - h(i - 1, j)) / (2 * grid.step), dzdy = (h(i, j + 1) - h(i, j - 1)) / (2 * grid.step);
        const nz = 1 / Math.sqrt(1 + dzdx * dzdx + dzdy * dzdy);
        const shade = Math.min(1, Math.max(0, (dzdx * 0.5 - dzdy * 0.5 + 0.75) * nz));   // light from the north-west
        let rgb = heightColour((z - lo) / Math.max(hi - lo, 1e-6)).map(c => c * (0.5 + 0.55 * shade));
        if (nz < 0.6641741) rgb = [rgb[0] * 0.55 + 90, rgb[1] * 0.55 + 18, rgb[2] * 0.55 + 18];   // too steep to walk
        const o = ((n - 1 - j) * n + i) * 4;   // row 0 of the grid is the south edge: the bottom of the image
        data.data[o] = rgb[0]; data.data[o + 1] = rgb[1]; data.data[o + 2] = rgb[2]; data.data[o + 3] = 255;
      }
    }
    g.putImageData(data, 0, 0);
    return img;
  }

  async function fetchJSON(url) {
    const r = await fetch(url);
    return { ok: r.ok, status: r.status, body: await r.json() };
  }

  const grids = new Map();
  async function refreshLandblocks() {
    let ids;
    try { ids = (await fetchJSON("/api/landblocks")).body; } catch (e) { return; }
    let added = false;
    for (const id of ids) {
      if (terrain.has(id)) continue;
      const lb = parseInt(id, 16);
      terrain.set(id, { x0: (lb >> 8) * LANDBLOCK_M, y0: (lb & 0xff) * LANDBLOCK_M, image: null });
      added = true;
      try {
        const r = await fetchJSON("/api/terrain/" + id);
        if (r.ok) grids.set(id, r.body);
      } catch (e) { /* drawn blank */ }
    }
    if (added) {
      // one colour scale for every landblock, so that heights compare across edges
      let lo = Infinity, hi = -Infinity;
      for (const g of grids.values()) { lo = Math.min(lo, g.min); hi = Math.max(hi, g.max); }
      for (const [id, g] of grids) terrain.get(id).image = terrainImage(g, lo - 10, hi + 5);
      if (!view.fitted) fit();
      dirty = true;
    }
  }

  // -- view ----------------------------------------------------------------------------------
  function bounds() {
    let x0 = Infinity, y0 = Infinity, x1 = -Infinity, y1 = -Infinity;
    for (const t of terrain.values()) {
      x0 = Math.min(x0, t.x0); y0 = Math.min(y0, t.y0); x1 = Math.max(x1, t.x0 + LANDBLOCK_M); y1 = Math.max(y1, t.y0 + LANDBLOCK_M);
    }
    for (const m of movers.values()) { x0 = Math.min(x0, m.x - 20); y0 = Math.min(y0, m.y - 20); x1 = Math.max(x1, m.x + 20); y1 = Math.max(y1, m.y + 20); }
    return isFinite(x0) ? [x0, y0, x1, y1] : null;
  }

  function fit() {
    const b = bounds();
    if (!b) return;
    view.cx = (b[0] + b[2]) / 2; view.cy = (b[1] + b[3]) / 2;
    view.scale = 0.92 * Math.min(canvas.width / (b[2] - b[0]), canvas.height / (b[3] - b[1]));
    view.fitted = true; dirty = true;
  }

  function toScreen(x, y) { return [canvas.width / 2 + (x - view.cx) * view.scale, canvas.height / 2 - (y - view.cy) * view.scale]; }
  function toWorld(px, py) { return [view.cx + (px - canvas.width / 2) / view.scale, view.cy - (py - canvas.height / 2) / view.scale]; }

  function resize() {
    const r = canvas.getBoundingClientRect();
    canvas.width = Math.max(1, Math.round(r.width)); canvas.height = Math.max(1, Math.round(r.height));
    dirty = true;
  }

  function drawScale() {
    const steps = [1, 2, 5, 10, 20, 50, 100, 200, 500, 1000];
    let m = steps[0];
    for (const s of steps) if (s * view.scale <= 160) m = s;
    const x = 12, y = canvas.height - 40;
    ctx.fillStyle = "rgba(255,255,255,0.85)"; ctx.fillRect(x - 6, y - 18, m * view.scale + 40, 28);
    ctx.fillStyle = "#000"; ctx.fillRect(x, y, m * view.scale, 4);
    ctx.font = "12px sans-serif"; ctx.fillText(m + " m", x, y - 5);
    // north
    const nx = canvas.width - 28, ny = 40;
    ctx.beginPath(); ctx.moveTo(nx, ny - 22); ctx.lineTo(nx - 8, ny); ctx.lineTo(nx + 8, ny); ctx.closePath(); ctx.fill();
    ctx.fillText("N", nx - 4, ny + 16);
  }

  function draw() {
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.fillStyle = "#445"; ctx.fillRect(0, 0, canvas.width, canvas.height);
    ctx.imageSmoothingEnabled = true;
    for (const [id, t] of terrain) {
      const [sx, sy] = toScreen(t.x0, t.y0 + LANDBLOCK_M), size = LANDBLOCK_M * view.scale;
      if (t.image) ctx.drawImage(t.image, sx, sy, size, size);
      else { ctx.fillStyle = "#667"; ctx.fillRect(sx, sy, size, size); }
      ctx.setLineDash([6, 4]); ctx.strokeStyle = "rgba(255,255,255,0.8)"; ctx.lineWidth = 1; ctx.strokeRect(sx, sy, size, size); ctx.setLineDash([]);
      ctx.fillStyle = "#fff"; ctx.font = "bold 12px sans-serif"; ctx.fillText("landblock " + id, sx + 4, sy + 14);
    }
    for (const [id, m] of movers) {
      const cls = contactClass(m.state);
      if (m.trail.length > 1) {
        ctx.beginPath();
        m.trail.forEach(([x, y], k) => { const [px, py] = toScreen(x, y); if (k) ctx.lineTo(px, py); else ctx.moveTo(px, py); });
        ctx.strokeStyle = "rgba(0,0,0,0.55)"; ctx.lineWidth = 1.5; ctx.stroke();
      }
      const [px, py] = toScreen(m.x, m.y);
      const r = Math.max(5, 0.48 * view.scale);
      ctx.beginPath(); ctx.arc(px, py, r, 0, 2 * Math.PI);
      ctx.fillStyle = COLOURS[cls]; ctx.fill();
      ctx.lineWidth = id === selected ? 3 : 1.2; ctx.strokeStyle = id === selected ? "#ffe000" : "#000"; ctx.stroke();
      ctx.fillStyle = "#000"; ctx.font = "11px monospace"; ctx.fillText(id.slice(-4), px + r + 2, py - r);
    }
    drawScale();
  }

  function frame() {
    if (dirty) { dirty = false; draw(); }
    requestAnimationFrame(frame);
  }

  // -- movers --------------------------------------------------------------------------------
  function describe(st) {
    const o = st.position.origin;
    return st.id + "  " + contactClass(st).padEnd(8) + " (" + o.map(v => v.toFixed(1)).join(", ") + ")";
  }

  function renderList() {
    countEl.textContent = String(movers.size);
    listEl.replaceChildren(...[...movers.keys()].sort().map(id => {
      const li = document.createElement("li");
      li.textContent = describe(movers.get(id).state);
      li.dataset.id = id;
      if (id === selected) li.className = "selected";
      li.addEventListener("click", () => select(id));
      return li;
    }));
  }

  function showState() {
    const m = selected && movers.get(selected);
    selectedEl.textContent = m ? selected : "(click a mover)";
    // one line per field: short arrays (origin, orientation, normals) stay on their line
    stateEl.textContent = m ? JSON.stringify(m.state, null, 1).replace(/\[\s+([^\[\]{}]*?)\s+\]/g,
      (_, inner) => "[" + inner.replace(/\s+/g, " ") + "]") : "";
  }

  function select(id) { selected = id; showState(); renderList(); dirty = true; }

  let listDue = false;
  function take(st) {
    const [x, y] = globalXY(st);
    let m = movers.get(st.id);
    if (!m) { m = { trail: [] }; movers.set(st.id, m); }
    m.state = st; m.x = x; m.y = y;
    m.trail.push([x, y]); if (m.trail.length > TRAIL) m.trail.shift();
    updates++;
    if (!terrain.has(lbHex(st.landblock))) refreshLandblocks();
    if (st.id === selected) showState();
    if (!listDue) { listDue = true; setTimeout(() => { listDue = false; renderList(); }, 250); }
    dirty = true;
  }

  function lbHex(lb) { return lb.toString(16).toUpperCase().padStart(4, "0"); }

  function nearestMover(px, py) {
    let best = null, bestD = 12;
    for (const [id, m] of movers) {
      const [sx, sy] = toScreen(m.x, m.y);
      const d = Math.hypot(sx - px, sy - py) - Math.max(5, 0.48 * view.scale);
      if (d < bestD) { bestD = d; best = id; }
    }
    return best;
  }

  // -- input ---------------------------------------------------------------------------------
  let drag = null;
  canvas.addEventListener("mousedown", e => { drag = { x: e.offsetX, y: e.offsetY, cx: view.cx, cy: view.cy, moved: false }; canvas.style.cursor = "grabbing"; });
  window.addEventListener("mouseup", e => {
    if (drag && !drag.moved && e.target === canvas) { const id = nearestMover(e.offsetX, e.offsetY); if (id) select(id); }
    drag = null; canvas.style.cursor = "grab";
  });
  canvas.addEventListener("mousemove", e => {
    if (!drag) return;
    const dx = e.offsetX - drag.x, dy = e.offsetY - drag.y;
    if (Math.abs(dx) + Math.abs(dy) > 3) drag.moved = true;
    view.cx = drag.cx - dx / view.scale; view.cy = drag.cy + dy / view.scale; dirty = true;
  });
  canvas.addEventListener("wheel", e => {
    e.preventDefault();
    const [wx, wy] = toWorld(e.offsetX, e.offsetY);
    view.scale = Math.min(200, Math.max(0.02, view.scale * Math.exp(-e.deltaY * 0.0015)));
    view.cx = wx - (e.offsetX - canvas.width / 2) / view.scale; view.cy = wy + (e.offsetY - canvas.height / 2) / view.scale;
    dirty = true;
  }, { passive: false });
  document.getElementById("fit").addEventListener("click", fit);
  window.addEventListener("resize", resize);

  // -- start ---------------------------------------------------------------------------------
  function setStatus(text) { statusEl.textContent = text; }

  async function start() {
    resize();
    try {
      info = (await fetchJSON("/api/info")).body;
    } catch (e) { setStatus("the view server does not answer"); return; }
    const who = info.instances && info.instances.length ? "instance " + info.instances.join(", ") : "no service answering yet";
    setStatus("prefix '" + info.prefix + "' via " + info.connect.join(", ") + " · " + who + " · terrain of " + info.world);
    await refreshLandblocks();
    for (const st of (await fetchJSON("/api/movers")).body) take(st);
    const events = new EventSource("/api/events");
    events.addEventListener("state", e => take(JSON.parse(e.data)));
    events.onopen = () => { statusEl.dataset.live = "1"; };
    setInterval(refreshLandblocks, 5000);
    setInterval(() => { dirty = true; }, 1000);   // stale colours
    requestAnimationFrame(frame);
  }

  // for tests and for the curious: read-only views of the page's state
  window.acphysView = {
    moverIds: () => [...movers.keys()],
    position: id => { const m = movers.get(id); return m ? [m.x, m.y] : null; },
    screenOf: id => { const m = movers.get(id); return m ? toScreen(m.x, m.y) : null; },
    updates: () => updates,
    landblocks: () => [...terrain.keys()],
    terrainReady: () => [...terrain.values()].filter(t => t.image).length,
    selected: () => selected,
  };
  start();
})();
