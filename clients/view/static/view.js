// acphys live map: terrain, buildings and objects of the service's landblocks and its movers, live
// (server-sent events: a `state` event per new State, a `removed` event per mover the service no longer holds).
// Coordinates: global metres, x = landblock column * 192 + local x, y likewise; north is up.
"use strict";

(function () {
  const LANDBLOCK_M = 192;
  const IDLE_S = 30;
  const TRAIL = 60;               // points of trail kept per mover
  const FLOOR_Z = 0.6641741;      // walkable limit: steeper terrain is tinted
  const COLOURS = { walkable: "#18c018", steep: "#ff8c00", air: "#1e5aff", idle: "#999999" };
  const BUILDING = { fill: "#d9c7a0", stroke: "#222222" };   // sandstone: apart from the reddish steep tint
  const OBJECT = { fill: "#7d7d7d", stroke: "#222222" };
  const PATH = { line: "#d0009a", halo: "rgba(255,255,255,0.85)", missing: "#555555" };
  const LABELS = window.acphysLabels;

  const canvas = document.getElementById("map");
  const ctx = canvas.getContext("2d");
  const statusEl = document.getElementById("status");
  const countEl = document.getElementById("mover-count");
  const listEl = document.getElementById("movers");
  const stateEl = document.getElementById("state");
  const selectedEl = document.getElementById("selected");
  const hintEl = document.getElementById("hint");
  const pathsEl = document.getElementById("paths");

  const view = { cx: 0, cy: 0, scale: 1, fitted: false };   // scale: pixels per metre
  const terrain = new Map();   // "A9B4" -> {x0, y0, image (canvas) or null}
  const outlines = new Map();  // "A9B4" -> {buildings: [...], objects: [...]} (global metres)
  const movers = new Map();    // id hex -> {state, x, y, trail: [[x, y], ...]}
  const heightRange = { lo: null, hi: null };   // of the terrain drawn (metres), for the key
  let paths = [];              // the paths asked (/api/paths): from, to, found, waypoints (landblock metres)
  let pathStart = null;        // the first shift-click's point, global metres, until the second
  let layout = { labels: [], fixed: {}, dots: [], paths: [] };   // where the last frame put things (for tests)
  let selected = null;
  let info = null;
  let updates = 0, removals = 0;
  let dirty = true;

  function contactClass(st) {
    if ((Date.now() / 1000 - st.received) > IDLE_S) return "idle";
    return st.on_walkable ? "walkable" : st.contact ? "steep" : "air";
  }

  function globalXY(st) {
    const lb = st.landblock;
    return [(lb >> 8) * LANDBLOCK_M + st.position.origin[0], (lb & 0xff) * LANDBLOCK_M + st.position.origin[1]];
  }

  function lbHex(lb) { return lb.toString(16).toUpperCase().padStart(4, "0"); }
  function cellHex(cell) { return cell.toString(16).toUpperCase().padStart(8, "0"); }

  // -- terrain -------------------------------------------------------------------------------
  function heightColour(t) {   // t in 0..1: green lowlands, brown hills, light tops
    const stops = [[0, [52, 120, 60]], [0.35, [118, 160, 74]], [0.6, [168, 140, 88]], [0.85, [150, 120, 100]], [1, [245, 245, 240]]];
    t = Math.min(1, Math.max(0, t));
    for (let i = 1; i < stops.length; i++) {
      if (t <= stops[i][0]) {
        const [t0, c0] = stops[i - 1], [t1, c1] = stops[i];
        const f = (t - t0) / (t1 - t0);
        return c0.map((c, k) => c + (c1[k] - c) * f);
      }
    }
    return stops[stops.length - 1][1];
  }

  // the colour scale reaches below the lowest ground and above the highest, as the images use it
  function scaleOf(lo, hi) { return { lo: lo - 10, hi: hi + 5 }; }
  function colourAt(z, sc) { return heightColour((z - sc.lo) / Math.max(sc.hi - sc.lo, 1e-6)); }
  function steepTint(rgb) { return [rgb[0] * 0.55 + 90, rgb[1] * 0.55 + 18, rgb[2] * 0.55 + 18]; }

  function terrainImage(grid, sc) {
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
        let rgb = colourAt(z, sc).map(c => c * (0.5 + 0.55 * shade));
        if (nz < FLOOR_Z) rgb = steepTint(rgb);   // too steep to walk
        const o = ((n - 1 - j) * n + i) * 4;   // row 0 of the grid is the south edge: the bottom of the image
        data.data[o] = rgb[0]; data.data[o + 1] = rgb[1]; data.data[o + 2] = rgb[2]; data.data[o + 3] = 255;
      }
    }
    g.putImageData(data, 0, 0);
    return img;
  }

  // -- the height key (in the side panel): the colours of the heights drawn, lowest to highest ---------
  function niceStep(span) {
    for (const s of [1, 2, 5, 10, 20, 50, 100, 200, 500, 1000, 2000]) if (span / s <= 5) return s;
    return 5000;
  }

  function drawHeightKey() {
    const bar = document.getElementById("height-key-bar"), ticks = document.getElementById("height-key-ticks");
    const { lo, hi } = heightRange;
    if (lo === null) return;
    const sc = scaleOf(lo, hi), g = bar.getContext("2d"), w = bar.width;
    for (let x = 0; x < w; x++) {
      const rgb = colourAt(lo + (hi - lo) * (x + 0.5) / w, sc);
      g.fillStyle = "rgb(" + rgb.map(Math.round).join(",") + ")"; g.fillRect(x, 0, 1, bar.height);
    }
    const mid = colourAt((lo + hi) / 2, sc);
    document.getElementById("swatch-steep").style.background = "rgb(" + steepTint(mid).map(Math.round).join(",") + ")";
    // the ends say the lowest and highest heights; nice round heights between, none crowding an end
    const marks = [[lo, lo.toFixed(1) + " m", "left"], [hi, hi.toFixed(1) + " m", "right"]];
    const step = niceStep(hi - lo);
    for (let z = Math.ceil(lo / step) * step; z < hi; z += step) {
      const f = (z - lo) / Math.max(hi - lo, 1e-6);
      if (f > 0.18 && f < 0.82) marks.push([z, z + " m", "centre"]);
    }
    ticks.replaceChildren(...marks.map(([z, text, align]) => {
      const s = document.createElement("span");
      const f = (z - lo) / Math.max(hi - lo, 1e-6);
      s.textContent = text; s.dataset.height = String(z);
      if (align === "left") s.style.left = "0px";
      else if (align === "right") s.style.right = "0px";
      else { s.style.left = (f * w) + "px"; s.style.transform = "translateX(-50%)"; }
      return s;
    }));
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
      try {
        const r = await fetchJSON("/api/objects/" + id);
        if (r.ok) outlines.set(id, r.body);
      } catch (e) { /* drawn without */ }
    }
    if (added) {
      // one colour scale for every landblock, so that heights compare across edges
      let lo = Infinity, hi = -Infinity;
      for (const g of grids.values()) { lo = Math.min(lo, g.min); hi = Math.max(hi, g.max); }
      if (isFinite(lo)) {
        heightRange.lo = lo; heightRange.hi = hi;
        for (const [id, g] of grids) terrain.get(id).image = terrainImage(g, scaleOf(lo, hi));
        drawHeightKey();
      }
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

  // the hint (an HTML box over the map's lower left) in canvas pixels
  function hintBox() {
    const c = canvas.getBoundingClientRect(), h = hintEl.getBoundingClientRect();
    return { x0: h.left - c.left, y0: h.top - c.top, x1: h.right - c.left, y1: h.bottom - c.top };
  }

  // the scale bar (just above the hint) and north (upper right); returns their boxes
  function drawScaleAndNorth(hint) {
    const steps = [1, 2, 5, 10, 20, 50, 100, 200, 500, 1000];
    let m = steps[0];
    for (const s of steps) if (s * view.scale <= 160) m = s;
    const x = 12, y = Math.min(canvas.height - 12, hint.y0 - 12);
    const scale = { x0: x - 6, y0: y - 18, x1: x + m * view.scale + 34, y1: y + 10 };
    ctx.fillStyle = "rgba(255,255,255,0.85)"; ctx.fillRect(scale.x0, scale.y0, scale.x1 - scale.x0, scale.y1 - scale.y0);
    ctx.fillStyle = "#000"; ctx.fillRect(x, y, m * view.scale, 4);
    ctx.font = "12px sans-serif"; ctx.textBaseline = "alphabetic"; ctx.fillText(m + " m", x, y - 5);
    const nx = canvas.width - 28, ny = 40;
    const north = { x0: nx - 12, y0: ny - 26, x1: nx + 12, y1: ny + 22 };
    ctx.fillStyle = "rgba(255,255,255,0.75)"; ctx.fillRect(north.x0, north.y0, north.x1 - north.x0, north.y1 - north.y0);
    ctx.fillStyle = "#000";
    ctx.beginPath(); ctx.moveTo(nx, ny - 22); ctx.lineTo(nx - 8, ny); ctx.lineTo(nx + 8, ny); ctx.closePath(); ctx.fill();
    ctx.fillText("N", nx - 4, ny + 16);
    return { scale, north };
  }

  // buildings and objects; returns what was drawn in sight: {kind, box} in canvas pixels
  function drawOutlines() {
    const drawn = [];
    for (const o of outlines.values()) {
      for (const [list, style, kind] of [[o.buildings, BUILDING, "building"], [o.objects, OBJECT, "object"]]) {
        for (const shape of list) {
          ctx.fillStyle = style.fill; ctx.strokeStyle = style.stroke; ctx.lineWidth = 1;
          const box = { x0: Infinity, y0: Infinity, x1: -Infinity, y1: -Infinity };
          const grow = (x0, y0, x1, y1) => { box.x0 = Math.min(box.x0, x0); box.y0 = Math.min(box.y0, y0); box.x1 = Math.max(box.x1, x1); box.y1 = Math.max(box.y1, y1); };
          if (shape.polygon.length) {
            ctx.beginPath();
            shape.polygon.forEach(([x, y], k) => {
              const [px, py] = toScreen(x, y);
              if (k) ctx.lineTo(px, py); else ctx.moveTo(px, py);
              grow(px, py, px, py);
            });
            ctx.closePath(); ctx.fill(); ctx.stroke();
          }
          for (const [x, y, r] of shape.circles) {
            const [px, py] = toScreen(x, y), rp = Math.max(1.5, r * view.scale);
            ctx.beginPath(); ctx.arc(px, py, rp, 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
            grow(px - rp, py - rp, px + rp, py + rp);
          }
          if (box.x1 > 0 && box.y1 > 0 && box.x0 < canvas.width && box.y0 < canvas.height) drawn.push({ kind, box });
        }
      }
    }
    return drawn;
  }

  function dotRadius() { return Math.max(5, 0.48 * view.scale); }

  // -- paths ---------------------------------------------------------------------------------
  function pointXY(p) { return [(p.landblock >> 8) * LANDBLOCK_M + p.origin[0], (p.landblock & 0xff) * LANDBLOCK_M + p.origin[1]]; }

  async function refreshPaths() {
    let got;
    try { got = (await fetchJSON("/api/paths")).body; } catch (e) { return; }
    if (JSON.stringify(got) !== JSON.stringify(paths)) { paths = got; renderPaths(); dirty = true; }
  }

  function describePath(p) {
    const head = "#" + p.number + " ";
    if (p.pending) return head + "asking the service…";
    if (p.error) return head + "not answered: " + p.error;
    if (!p.found) return head + "no path: " + p.reason + (p.detail ? " (" + p.detail + ")" : "");
    return head + p.length.toFixed(1) + " m, " + p.waypoints.length + " waypoints, " + p.to.cell;
  }

  function renderPaths() {
    pathsEl.replaceChildren(...paths.map(p => {
      const li = document.createElement("li");
      li.textContent = describePath(p);
      li.className = p.pending ? "pending" : p.found ? "found" : "missing";
      return li;
    }));
  }

  // each path's waypoints as a polyline (a dot at each waypoint, the start a circle, the goal a square); one not
  // found as a thin dashed line from where to where; returns what was drawn, in canvas pixels
  function drawPaths() {
    const drawn = [];
    for (const p of paths) {
      const found = p.found && p.waypoints.length > 1;
      const pts = (found ? p.waypoints : [p.from, p.to]).map(w => toScreen(...pointXY(w)));
      ctx.beginPath();
      pts.forEach(([px, py], k) => { if (k) ctx.lineTo(px, py); else ctx.moveTo(px, py); });
      if (found) {
        ctx.strokeStyle = PATH.halo; ctx.lineWidth = 5; ctx.stroke();
        ctx.strokeStyle = PATH.line; ctx.lineWidth = 2.5; ctx.stroke();
        ctx.fillStyle = PATH.line;
        for (const [px, py] of pts) { ctx.beginPath(); ctx.arc(px, py, 3, 0, 2 * Math.PI); ctx.fill(); }
      } else {
        ctx.setLineDash([5, 5]); ctx.strokeStyle = PATH.missing; ctx.lineWidth = 1.5; ctx.stroke(); ctx.setLineDash([]);
      }
      const [sx, sy] = pts[0], [ex, ey] = pts[pts.length - 1];
      ctx.lineWidth = 1.5; ctx.strokeStyle = "#000";
      ctx.fillStyle = "#00a000"; ctx.beginPath(); ctx.arc(sx, sy, 6, 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
      ctx.fillStyle = found ? "#c00000" : PATH.missing; ctx.fillRect(ex - 5, ey - 5, 10, 10); ctx.strokeRect(ex - 5, ey - 5, 10, 10);
      drawn.push({ number: p.number, found, pending: !!p.pending, points: pts });
    }
    if (pathStart) {   // the first shift-click, waiting for the second
      const [px, py] = toScreen(pathStart[0], pathStart[1]);
      ctx.fillStyle = "#00a000"; ctx.strokeStyle = "#fff"; ctx.lineWidth = 2;
      ctx.beginPath(); ctx.arc(px, py, 6, 0, 2 * Math.PI); ctx.fill(); ctx.stroke();
    }
    return drawn;
  }

  async function pathClick(px, py) {
    const xy = toWorld(px, py);
    if (!pathStart) { pathStart = xy; dirty = true; setHint("shift-click the goal"); return; }
    const from = pathStart;
    pathStart = null; dirty = true; setHint("asking the service for a path…");
    try {
      const r = await fetch("/api/path", { method: "POST", headers: { "Content-Type": "application/json" },
                                          body: JSON.stringify({ from, to: xy }) });
      const body = await r.json();
      setHint(r.ok ? describePath(body) : body.error);
    } catch (e) { setHint("the view server does not answer"); }
    await refreshPaths();
  }

  function setHint(text) { document.getElementById("path-hint").textContent = text; }

  function draw() {
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    ctx.fillStyle = "#445"; ctx.fillRect(0, 0, canvas.width, canvas.height);
    ctx.imageSmoothingEnabled = true;
    const squares = [];
    for (const [id, t] of terrain) {
      const [sx, sy] = toScreen(t.x0, t.y0 + LANDBLOCK_M), size = LANDBLOCK_M * view.scale;
      if (t.image) ctx.drawImage(t.image, sx, sy, size, size);
      else { ctx.fillStyle = "#667"; ctx.fillRect(sx, sy, size, size); }
      ctx.setLineDash([6, 4]); ctx.strokeStyle = "rgba(255,255,255,0.8)"; ctx.lineWidth = 1; ctx.strokeRect(sx, sy, size, size); ctx.setLineDash([]);
      squares.push([id, { x0: sx, y0: sy, x1: sx + size, y1: sy + size }]);
    }
    const shapes = drawOutlines();
    const drawnPaths = drawPaths();
    const r = dotRadius(), dots = [];
    for (const [id, m] of movers) {
      const cls = contactClass(m.state);
      if (m.trail.length > 1) {
        ctx.beginPath();
        m.trail.forEach(([x, y], k) => { const [px, py] = toScreen(x, y); if (k) ctx.lineTo(px, py); else ctx.moveTo(px, py); });
        ctx.strokeStyle = "rgba(0,0,0,0.55)"; ctx.lineWidth = 1.5; ctx.stroke();
      }
      const [px, py] = toScreen(m.x, m.y);
      ctx.beginPath(); ctx.arc(px, py, r, 0, 2 * Math.PI);
      ctx.fillStyle = COLOURS[cls]; ctx.fill();
      ctx.lineWidth = id === selected ? 3 : 1.2; ctx.strokeStyle = id === selected ? "#ffe000" : "#000"; ctx.stroke();
      dots.push({ id, x: px, y: py, r });
    }
    const hint = hintBox();
    const fixed = drawScaleAndNorth(hint);
    fixed.hint = hint;
    drawLabels(squares, dots, fixed);
    layout.shapes = shapes;
    layout.paths = drawnPaths;
  }

  // landblock names and mover ids, each where it covers no other label, no mover and none of the fixed marks
  function drawLabels(squares, dots, fixed) {
    const view_ = { x0: 0, y0: 0, x1: canvas.width, y1: canvas.height };
    const requests = [], kinds = [];
    const pad = 3;
    const measure = (text, font) => { ctx.font = font; return ctx.measureText(text).width + 2 * pad; };
    const moverFont = "11px monospace", lbFont = "bold 12px sans-serif";
    const byPriority = [...dots].sort((a, b) => (b.id === selected) - (a.id === selected) || (a.id < b.id ? -1 : 1));
    for (const d of byPriority) {
      const text = d.id.slice(-4), w = measure(text, moverFont), h = 15;
      requests.push({ w, h, places: LABELS.aroundDot(d.x, d.y, d.r, w, h), always: d.id === selected });
      kinds.push({ kind: "mover", id: d.id, text, font: moverFont, fg: "#000", bg: "rgba(255,255,255,0.8)", dot: d });
    }
    for (const [id, sq] of squares) {
      // the part of the landblock in sight: its name follows it when the corner is out of view
      const vis = { x0: Math.max(sq.x0, 0), y0: Math.max(sq.y0, 0), x1: Math.min(sq.x1, canvas.width), y1: Math.min(sq.y1, canvas.height) };
      const text = "landblock " + id, w = measure(text, lbFont), h = 17;
      const places = vis.x1 - vis.x0 > w + 8 && vis.y1 - vis.y0 > h + 8 ? LABELS.inCorners(vis, w, h) : [];
      requests.push({ w, h, places });
      kinds.push({ kind: "landblock", id, text, font: lbFont, fg: "#fff", bg: "rgba(0,0,0,0.45)" });
    }
    const obstacles = [fixed.scale, fixed.north, fixed.hint, ...dots.map(d => ({ x0: d.x - d.r - 1, y0: d.y - d.r - 1, x1: d.x + d.r + 1, y1: d.y + d.r + 1 }))];
    const placed = LABELS.place(requests, obstacles, view_);
    const labels = [];
    placed.forEach((p, k) => {
      const L = kinds[k], leader = p.shown && p.ring > 0;
      labels.push({ kind: L.kind, id: L.id, text: L.text, shown: p.shown, box: p.box, leader });
      if (!p.shown) return;
      const b = p.box;
      if (leader) {   // moved out of the crowd: a line from the dot's edge to the label's nearest point
        const d = L.dot, nx = Math.min(Math.max(d.x, b.x0), b.x1), ny = Math.min(Math.max(d.y, b.y0), b.y1);
        const len = Math.hypot(nx - d.x, ny - d.y) || 1;
        ctx.beginPath(); ctx.moveTo(d.x + (nx - d.x) / len * d.r, d.y + (ny - d.y) / len * d.r); ctx.lineTo(nx, ny);
        ctx.strokeStyle = "rgba(0,0,0,0.8)"; ctx.lineWidth = 1; ctx.stroke();
      }
      ctx.fillStyle = L.bg; ctx.fillRect(b.x0, b.y0, b.x1 - b.x0, b.y1 - b.y0);
      ctx.fillStyle = L.fg; ctx.font = L.font; ctx.textBaseline = "middle";
      ctx.fillText(L.text, b.x0 + pad, (b.y0 + b.y1) / 2 + 0.5);
    });
    ctx.textBaseline = "alphabetic";
    layout = { labels, fixed, dots: dots.map(d => ({ id: d.id, x: d.x, y: d.y, r: d.r })), canvas: { w: canvas.width, h: canvas.height } };
  }

  function frame() {
    if (dirty) { dirty = false; draw(); }
    requestAnimationFrame(frame);
  }

  // -- movers --------------------------------------------------------------------------------
  function describe(st) {
    const o = st.position.origin;
    return st.id + "  " + contactClass(st).padEnd(8) + " " + lbHex(st.landblock) + " " + o.map(v => v.toFixed(1)).join(", ");
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

  function two(n) { return String(n).padStart(2, "0"); }

  function humanTime(t) {   // seconds since the epoch -> local "HH:MM:SS (N s ago)"
    const d = new Date(t * 1000), ago = Math.max(0, Math.round(Date.now() / 1000 - t));
    const clock = two(d.getHours()) + ":" + two(d.getMinutes()) + ":" + two(d.getSeconds());
    return clock + " (" + (ago < 120 ? ago + " s" : Math.round(ago / 60) + " min") + " ago)";
  }

  // the State as the panel shows it: every id in hex (mover, landblock, cells), the time it came as a clock
  function forPanel(st) {
    const o = JSON.parse(JSON.stringify(st));
    delete o.id_hex; delete o.cell_hex;
    o.landblock = lbHex(st.landblock);
    if (o.position && typeof st.position.cell === "number") o.position.cell = cellHex(st.position.cell);
    if (typeof st.contact_plane_cell === "number") o.contact_plane_cell = cellHex(st.contact_plane_cell);
    o.received = humanTime(st.received);
    return o;
  }

  function showState() {
    const m = selected && movers.get(selected);
    if (!m) { if (!selected) { selectedEl.textContent = "(click a mover)"; stateEl.textContent = ""; } return; }
    selectedEl.textContent = selected;
    // one line per field: short arrays (origin, orientation, normals) stay on their line
    stateEl.textContent = JSON.stringify(forPanel(m.state), null, 1).replace(/\[\s+([^\[\]{}]*?)\s+\]/g,
      (_, inner) => "[" + inner.replace(/\s+/g, " ") + "]");
  }

  function select(id) { selected = id; showState(); renderList(); dirty = true; }

  let listDue = false;
  function listSoon() {
    if (!listDue) { listDue = true; setTimeout(() => { listDue = false; renderList(); }, 250); }
  }

  function take(st) {
    const [x, y] = globalXY(st);
    let m = movers.get(st.id);
    if (!m) { m = { trail: [] }; movers.set(st.id, m); }
    m.state = st; m.x = x; m.y = y;
    m.trail.push([x, y]); if (m.trail.length > TRAIL) m.trail.shift();
    updates++;
    if (!terrain.has(lbHex(st.landblock))) refreshLandblocks();
    if (st.id === selected) showState();
    listSoon();
    dirty = true;
  }

  function drop(id) {   // the service no longer holds it
    if (!movers.delete(id)) return;
    removals++;
    if (id === selected) {   // it stays selected: the panel says so until another is clicked (or it returns)
      selectedEl.textContent = id + " (removed)";
      stateEl.textContent = "";
    }
    listSoon();
    dirty = true;
  }

  function nearestMover(px, py) {
    let best = null, bestD = 12;
    for (const [id, m] of movers) {
      const [sx, sy] = toScreen(m.x, m.y);
      const d = Math.hypot(sx - px, sy - py) - dotRadius();
      if (d < bestD) { bestD = d; best = id; }
    }
    return best;
  }

  // -- input ---------------------------------------------------------------------------------
  let drag = null;
  canvas.addEventListener("mousedown", e => { drag = { x: e.offsetX, y: e.offsetY, cx: view.cx, cy: view.cy, moved: false }; canvas.style.cursor = "grabbing"; });
  window.addEventListener("mouseup", e => {
    if (drag && !drag.moved && e.target === canvas) {
      if (e.shiftKey) pathClick(e.offsetX, e.offsetY);
      else { const id = nearestMover(e.offsetX, e.offsetY); if (id) select(id); }
    }
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
    events.addEventListener("removed", e => drop(JSON.parse(e.data).id));
    events.onopen = () => { statusEl.dataset.live = "1"; };
    await refreshPaths();
    setInterval(refreshLandblocks, 5000);
    setInterval(refreshPaths, 2000);   // a --path answered meanwhile, or another page's
    setInterval(() => { dirty = true; showState(); }, 1000);   // idle colours, "s ago"
    requestAnimationFrame(frame);
  }

  // for tests and for the curious: read-only views of the page's state
  window.acphysView = {
    moverIds: () => [...movers.keys()],
    position: id => { const m = movers.get(id); return m ? [m.x, m.y] : null; },
    screenOf: id => { const m = movers.get(id); return m ? toScreen(m.x, m.y) : null; },
    toScreen: (x, y) => toScreen(x, y),
    updates: () => updates,
    removals: () => removals,
    landblocks: () => [...terrain.keys()],
    terrainReady: () => [...terrain.values()].filter(t => t.image).length,
    outlines: () => [...outlines.values()],
    heightRange: () => ({ lo: heightRange.lo, hi: heightRange.hi }),
    layout: () => JSON.parse(JSON.stringify(layout)),
    paths: () => JSON.parse(JSON.stringify(paths)),
    selected: () => selected,
    view: () => ({ cx: view.cx, cy: view.cy, scale: view.scale }),
    setView: (cx, cy, scale) => { view.cx = cx; view.cy = cy; view.scale = scale; view.fitted = true; dirty = true; },
  };
  start();
})();
