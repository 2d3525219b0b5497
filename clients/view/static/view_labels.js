// acphys live map: placing the map's labels so that none covers another, a mover or the map's fixed marks.
// Boxes are canvas pixels {x0, y0, x1, y1} (y down). Each request lists its candidate places in order of
// preference ([x0, y0, ring]: ring 0 next to its mark, further rings away from it, to be drawn with a
// leader line back); the first inside the bounds and clear of the obstacles and of the labels already
// placed wins. A label with no clear place is hidden, unless it must be shown (the selected mover's),
// when it takes its first place anyway.
"use strict";

window.acphysLabels = (function () {
  function overlaps(a, b) {
    return Math.min(a.x1, b.x1) > Math.max(a.x0, b.x0) && Math.min(a.y1, b.y1) > Math.max(a.y0, b.y0);
  }

  function inside(a, b) {
    return a.x0 >= b.x0 && a.x1 <= b.x1 && a.y0 >= b.y0 && a.y1 <= b.y1;
  }

  // requests: [{w, h, places: [[x0, y0, ring], ...], always?}, ...] in order of priority (earlier: better
  // places); returns, for each, {box, shown, ring}: box null when hidden
  function place(requests, obstacles, bounds) {
    const placed = [];
    return requests.map(req => {
      for (const [x, y, ring] of req.places) {
        const box = { x0: x, y0: y, x1: x + req.w, y1: y + req.h };
        if (!inside(box, bounds)) continue;
        if (obstacles.some(o => overlaps(box, o)) || placed.some(p => overlaps(box, p))) continue;
        placed.push(box);
        return { box, shown: true, ring: ring || 0 };
      }
      if (req.always && req.places.length) {
        const [x, y, ring] = req.places[0];
        const box = { x0: x, y0: y, x1: x + req.w, y1: y + req.h };
        placed.push(box);
        return { box, shown: true, ring: ring || 0 };
      }
      return { box: null, shown: false, ring: 0 };
    });
  }

  // the places around a dot of radius r at (px, py) for a w x h label: beside it first, then above and
  // below; the same again two rings further out (RING_PX apart)
  const RING_PX = 12;
  function aroundDot(px, py, r, w, h) {
    const out = [];
    for (let ring = 0; ring <= 2; ring++) {
      const g = 2 + ring * RING_PX, lift = ring ? 0 : 2;   // ring 0 tucks the box against the dot
      out.push(
        [px + r + g, py - r - h + lift - ring * RING_PX, ring], [px + r + g, py + r - lift + ring * RING_PX, ring],
        [px - r - g - w, py - r - h + lift - ring * RING_PX, ring], [px - r - g - w, py + r - lift + ring * RING_PX, ring],
        [px + r + g, py - h / 2, ring], [px - r - g - w, py - h / 2, ring],
        [px - w / 2, py - r - g - h, ring], [px - w / 2, py + r + g, ring]);
    }
    return out;
  }

  // the places in a rectangle's corners (inset by 4 px), then down its left and right edges
  function inCorners(rect, w, h) {
    const m = 4, out = [[rect.x0 + m, rect.y0 + m, 0], [rect.x1 - m - w, rect.y0 + m, 0],
      [rect.x0 + m, rect.y1 - m - h, 0], [rect.x1 - m - w, rect.y1 - m - h, 0]];
    for (let k = 1; k <= 6; k++) {   // a landblock's name needs no leader: it is inside its square
      out.push([rect.x0 + m, rect.y0 + m + k * (h + 4), 0], [rect.x1 - m - w, rect.y0 + m + k * (h + 4), 0]);
    }
    return out;
  }

  return { place, overlaps, inside, aroundDot, inCorners };
})();
