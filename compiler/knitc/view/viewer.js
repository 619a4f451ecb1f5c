/* knitc's interactive viewer (`knitc view FILE --html`).
 *
 * The page embeds everything as JSON (script#knitc-data, written by knitc/view/html.py):
 * the machine program's ops as columns, and for a design the stitches with their chart and
 * shape coordinates, the source spans, the text of every source line used, and the warnings.
 * This script only draws: the geometry was computed by knitc, so what is drawn is what knitc
 * computed.
 *
 * Each view is a set of items (ops on the bed, stitches in the chart and the shape) at world
 * coordinates, one unit per needle or stitch, y up. A camera maps them to the canvas; the
 * wheel zooms around the mouse and a drag pans. Items are drawn as rectangles grouped by
 * colour (one fillStyle per group, so 100k items draw in a few milliseconds) and found under
 * the mouse through a grid of unit buckets.
 *
 * window.knitcViewer is the page's API for tests and for a person at the console: show a
 * view, focus an item, read where an item is drawn, select a warning.
 */
(function () {
  "use strict";

  const D = JSON.parse(document.getElementById("knitc-data").textContent);
  const OPS = D.ops;
  const ST = D.stitches || null;

  // ---- colours ------------------------------------------------------------------------------

  const KIND_COLOURS = {
    knit: "#4c78a8",
    tuck: "#f58518",
    split: "#b279a2",
    xfer: "#54a24b",
    miss: "#bab0ac",
    drop: "#e45756",
    amiss: "#9ecae9",
  };
  const INSTR_COLOURS = {
    K: "#4c78a8",
    P: "#e45756",
    T: "#f58518",
    M: "#bab0ac",
    S: "#9d755d",
  };
  const MOVE_COLOUR = "#54a24b"; // FR1 FR2 FL1 FL2 BR1 BR2 BL1 BL2: lace moves
  const CROSS_COLOUR = "#b279a2"; // XR+ XR- XL+ XL-: cables
  const NODE_COLOURS = [
    "#4c78a8", "#f58518", "#54a24b", "#e45756", "#72b7b2",
    "#eeca3b", "#b279a2", "#ff9da6", "#9d755d", "#79706e",
  ];
  const HIGHLIGHT = "#ff00ff";
  const HOVER = "#000000";

  function instrColour(name) {
    if (INSTR_COLOURS[name]) return INSTR_COLOURS[name];
    return name.charAt(0) === "X" ? CROSS_COLOUR : MOVE_COLOUR;
  }

  // ---- text of ops, stitches and spans --------------------------------------------------------

  function needleText(bed, n) {
    return bed < 0 ? "" : D.beds[bed] + n;
  }

  function opText(i) {
    const k = D.kinds[OPS.kind[i]];
    const n = needleText(OPS.bed[i], OPS.needle[i]);
    const n2 = needleText(OPS.bed2[i], OPS.needle2[i]);
    const cs = OPS.carriers[i] >= 0 ? OPS.carrier_sets[OPS.carriers[i]] : "";
    const d = OPS.dir[i] > 0 ? "+" : "-";
    if (k === "knit" || k === "tuck" || k === "miss") return [k, d, n, cs].join(" ").trim();
    if (k === "split") return [k, d, n, n2, cs].join(" ").trim();
    if (k === "xfer") return "xfer " + n + " " + n2;
    if (k === "drop" || k === "amiss") return k + " " + n;
    return (k + " " + cs).trim();
  }

  /* The chain of a span, outermost (the designer's line) first: [location, line text]. */
  function spanChain(si) {
    const out = [];
    while (si >= 0) {
      const s = D.spans[si];
      const text = D.lines[s[0] + ":" + s[1]];
      out.unshift([D.files[s[0]] + ":" + s[1] + ":" + s[2], s[1], text === undefined ? "" : text]);
      si = s[3];
    }
    return out;
  }

  function spanLines(si, label) {
    const chain = spanChain(si);
    const lines = [];
    chain.forEach(function (c, j) {
      lines.push((j === 0 ? label : "  in ") + c[0]);
      lines.push("  " + c[1] + " | " + c[2].trim());
    });
    return lines;
  }

  function stitchSummary(s) {
    const side = ST.side[s] ? "back" : "front";
    return (
      "stitch " + s + ": node " + ST.nodes[ST.node[s]] + ", course " + ST.course[s] +
      ", wale " + ST.wale[s] + (ST.circular[s] ? " (" + side + ")" : "")
    );
  }

  function instrText(s) {
    let t = "instruction " + D.instructions[ST.instr[s]];
    if (ST.action[s] >= 0) t += ", action " + (ST.action_names[ST.action[s]] || ST.action[s]);
    return t;
  }

  function stitchTooltip(s) {
    const lines = [stitchSummary(s)];
    const op = ST.op[s];
    if (op >= 0) {
      lines.push("needle " + needleText(OPS.bed[op], OPS.needle[op]) + ": " + opText(op) +
        " (op " + op + (OPS.pass[op] >= 0 ? ", pass " + OPS.pass[op] : "") + ")");
    }
    lines.push(instrText(s));
    lines.push.apply(lines, spanLines(ST.span[s], ""));
    if (ST.origin[s] >= 0) lines.push.apply(lines, spanLines(ST.origin[s], "pattern "));
    return lines;
  }

  function opTooltip(i) {
    const lines = ["op " + i + ": " + opText(i)];
    lines.push(
      "needle " + needleText(OPS.bed[i], OPS.needle[i]) + ", pass " + OPS.pass[i] +
      ", racking " + OPS.racking[i] + (OPS.phase[i] > 0 ? ", " + D.phases[OPS.phase[i]] : "")
    );
    const s = OPS.stitch[i];
    if (s >= 0 && ST && s < ST.count) {
      lines.push(stitchSummary(s));
      lines.push(instrText(s));
    } else if (s >= 0) {
      lines.push("stitch " + s);
    }
    lines.push.apply(lines, spanLines(OPS.span[i], ""));
    return lines;
  }

  // ---- views ----------------------------------------------------------------------------------

  /* A view: n items at (x, y) with size (w, h), each an op or a stitch (`ids`), a colour
   * index into `palette`, and text labels [text, x, y] drawn over it. */
  function makeView(name, what, ids, x, y, w, h, colourOf, palette) {
    const n = ids.length;
    const v = {
      name: name, what: what, n: n, ids: ids, x: x, y: y, w: w, h: h,
      palette: palette, colour: new Uint16Array(n), labels: [], axes: null,
      byId: new Map(), buckets: new Map(), groups: [],
    };
    const groups = palette.map(function () { return []; });
    for (let i = 0; i < n; i++) {
      const c = colourOf(i);
      v.colour[i] = c;
      groups[c].push(i);
      v.byId.set(ids[i], i);
      const key = bucketKey(Math.floor(x[i]), Math.floor(y[i]));
      const b = v.buckets.get(key);
      if (b) b.push(i); else v.buckets.set(key, [i]);
    }
    v.groups = groups;
    let x0 = Infinity, x1 = -Infinity, y0 = Infinity, y1 = -Infinity;
    for (let i = 0; i < n; i++) {
      if (x[i] < x0) x0 = x[i];
      if (x[i] > x1) x1 = x[i];
      if (y[i] < y0) y0 = y[i];
      if (y[i] > y1) y1 = y[i];
    }
    v.bounds = n ? [x0 - w, y0 - h, x1 + w, y1 + h] : [0, 0, 1, 1];
    return v;
  }

  function bucketKey(ix, iy) {
    return (ix + 1048576) * 2097152 + (iy + 1048576);
  }

  function paletteOf(names, colourFn) {
    const index = {};
    const palette = [];
    names.forEach(function (nm) {
      const c = colourFn(nm);
      if (!(c in index)) {
        index[c] = palette.length;
        palette.push({ colour: c, labels: [] });
      }
      palette[index[c]].labels.push(nm);
    });
    return { palette: palette, index: function (nm) { return index[colourFn(nm)]; } };
  }

  const PASS_PITCH = 2.4; // a pass is two rows of needles (front, back) and a gap

  function bedView() {
    const ids = [];
    for (let i = 0; i < OPS.count; i++) if (OPS.pass[i] >= 0 && OPS.bed[i] >= 0) ids.push(i);
    const n = ids.length;
    const x = new Float64Array(n), y = new Float64Array(n);
    const kinds = D.kinds.filter(function (k) { return KIND_COLOURS[k]; });
    const pal = paletteOf(kinds, function (k) { return KIND_COLOURS[k]; });
    ids.forEach(function (op, i) {
      const back = D.beds[OPS.bed[op]].charAt(0) === "b";
      x[i] = OPS.needle[op];
      y[i] = OPS.pass[op] * PASS_PITCH + (back ? 1.5 : 0.5);
    });
    const v = makeView("bed", "op", ids, x, y, 0.9, 0.9, function (i) {
      return pal.index(D.kinds[OPS.kind[ids[i]]]);
    }, pal.palette);
    v.axes = bedAxes;
    v.note = "each pass is a row: front bed below, back bed above; needles across";
    return v;
  }

  function chartView() {
    const n = ST.count;
    const ids = new Int32Array(n);
    for (let i = 0; i < n; i++) ids[i] = i;
    const pal = paletteOf(D.instructions, instrColour);
    const v = makeView("chart", "stitch", ids, ST.chart_x, ST.chart_y, 0.9, 0.9, function (i) {
      return pal.index(D.instructions[ST.instr[i]]);
    }, pal.palette);
    ST.panels.forEach(function (p) {
      v.labels.push([p[0], p[1] + p[3] / 2 - 0.5, p[2] + p[4] + 0.6, "bold "]);
      if (p[5] > 0) {
        v.labels.push(["front", p[1] + p[5] / 2 - 0.5, p[2] - 1.2, ""]);
        v.labels.push(["back", p[1] + p[3] - p[5] / 2 - 0.5, p[2] - 1.2, ""]);
      }
    });
    v.note = "courses up, wales across; a tube's back face on the right, seen from behind";
    return v;
  }

  function shapeView() {
    const n = ST.count;
    const ids = new Int32Array(n);
    for (let i = 0; i < n; i++) ids[i] = i;
    const palette = ST.nodes.map(function (nm, j) {
      return { colour: NODE_COLOURS[j % NODE_COLOURS.length], labels: [nm] };
    });
    const v = makeView("shape", "stitch", ids, ST.shape_x, ST.shape_y, 0.8, 0.8, function (i) {
      return ST.node[i];
    }, palette);
    v.note = ST.shape_from === "layout"
      ? "the garment's shape: the stitch graph laid out flat, coloured by node"
      : "the garment's shape (no layout available: wale across, course up), coloured by node";
    return v;
  }

  const views = {};
  function getView(name) {
    if (!(name in views)) {
      if (name === "bed") views[name] = bedView();
      else views[name] = ST ? (name === "chart" ? chartView() : shapeView()) : null;
    }
    return views[name];
  }

  // ---- the canvas and the camera ----------------------------------------------------------------

  const canvas = document.getElementById("canvas");
  const stage = document.getElementById("stage");
  const ctx = canvas.getContext("2d");
  // The hover outline has a canvas of its own, so moving the mouse never redraws the items.
  const overlay = document.getElementById("overlay");
  const octx = overlay.getContext("2d");
  const tooltip = document.getElementById("tooltip");
  const notice = document.getElementById("notice");
  const cams = {};
  let current = "bed";
  let hover = -1; // item index in the current view
  let selected = -1; // warning index
  let highlight = []; // item indices in the current view
  let cssW = 1, cssH = 1;

  function view() { return getView(current); }

  function resize() {
    const dpr = window.devicePixelRatio || 1;
    cssW = Math.max(1, stage.clientWidth);
    cssH = Math.max(1, stage.clientHeight);
    [canvas, overlay].forEach(function (cv) {
      cv.width = Math.round(cssW * dpr);
      cv.height = Math.round(cssH * dpr);
      cv.style.width = cssW + "px";
      cv.style.height = cssH + "px";
      cv.getContext("2d").setTransform(dpr, 0, 0, dpr, 0, 0);
    });
  }

  /* The camera: screen x = tx + x * s, screen y = ty - y * s (y up). */
  function fit(v) {
    const b = v.bounds;
    const bw = b[2] - b[0], bh = b[3] - b[1];
    const pad = 24;
    let s = Math.min((cssW - 2 * pad) / bw, (cssH - 2 * pad) / bh);
    const wide = (cssW - 2 * pad) / bw;
    let bottom = false;
    if (v.name === "bed" && s < wide / 4) {
      // A long program: fit the needles across and start at the first pass.
      s = Math.min(wide, 24);
      bottom = true;
    }
    s = Math.max(s, 1e-3);
    const tx = cssW / 2 - ((b[0] + b[2]) / 2) * s;
    const ty = bottom ? cssH - pad + b[1] * s : cssH / 2 + ((b[1] + b[3]) / 2) * s;
    return { s: s, tx: tx, ty: ty };
  }

  function cam() {
    if (!cams[current]) cams[current] = fit(view());
    return cams[current];
  }

  function toScreen(c, x, y) { return [c.tx + x * c.s, c.ty - y * c.s]; }
  function toWorld(c, sx, sy) { return [(sx - c.tx) / c.s, (c.ty - sy) / c.s]; }

  // ---- drawing ------------------------------------------------------------------------------

  let pending = false;
  function redraw() {
    if (!pending) {
      pending = true;
      window.requestAnimationFrame(function () { pending = false; draw(); });
    }
  }

  function draw() {
    ctx.clearRect(0, 0, cssW, cssH);
    ctx.fillStyle = "#ffffff";
    ctx.fillRect(0, 0, cssW, cssH);
    const v = view();
    if (!v) return;
    const c = cam();
    const w = Math.max(1, v.w * c.s), h = Math.max(1, v.h * c.s);
    v.groups.forEach(function (group, ci) {
      ctx.fillStyle = v.palette[ci].colour;
      for (let k = 0; k < group.length; k++) {
        const i = group[k];
        const sx = c.tx + v.x[i] * c.s - w / 2, sy = c.ty - v.y[i] * c.s - h / 2;
        if (sx > cssW || sy > cssH || sx + w < 0 || sy + h < 0) continue;
        ctx.fillRect(sx, sy, w, h);
      }
    });
    if (highlight.length) {
      ctx.strokeStyle = HIGHLIGHT;
      ctx.lineWidth = 3;
      highlight.forEach(function (i) {
        const p = toScreen(c, v.x[i], v.y[i]);
        ctx.strokeRect(p[0] - w / 2 - 2, p[1] - h / 2 - 2, w + 4, h + 4);
      });
    }
    drawLabels(v, c);
    if (v.axes) v.axes(v, c);
    drawHover();
  }

  function drawHover() {
    octx.clearRect(0, 0, cssW, cssH);
    const v = view();
    if (!v || hover < 0) return;
    const c = cam();
    const w = Math.max(1, v.w * c.s), h = Math.max(1, v.h * c.s);
    const p = toScreen(c, v.x[hover], v.y[hover]);
    octx.strokeStyle = HOVER;
    octx.lineWidth = 2;
    octx.strokeRect(p[0] - w / 2 - 1, p[1] - h / 2 - 1, w + 2, h + 2);
  }

  function drawLabels(v, c) {
    if (!v.labels.length) return;
    const px = Math.max(10, Math.min(16, c.s * 1.2));
    ctx.fillStyle = "#222222";
    ctx.textAlign = "center";
    ctx.textBaseline = "middle";
    v.labels.forEach(function (l) {
      ctx.font = l[3] + px + "px sans-serif";
      const p = toScreen(c, l[1], l[2]);
      ctx.fillText(l[0], p[0], p[1]);
    });
  }

  function niceStep(pxPerUnit, minPx) {
    const steps = [1, 2, 5, 10, 20, 50, 100, 200, 500, 1000, 2000, 5000, 10000];
    for (let i = 0; i < steps.length; i++) if (steps[i] * pxPerUnit >= minPx) return steps[i];
    return steps[steps.length - 1];
  }

  function bedAxes(v, c) {
    ctx.fillStyle = "rgba(255,255,255,0.85)";
    ctx.fillRect(0, cssH - 18, cssW, 18);
    ctx.fillRect(0, 0, 44, cssH);
    ctx.fillStyle = "#333333";
    ctx.font = "11px sans-serif";
    ctx.textBaseline = "middle";
    ctx.textAlign = "center";
    const ns = niceStep(c.s, 40);
    const n0 = Math.ceil(toWorld(c, 44, 0)[0] / ns) * ns;
    const n1 = toWorld(c, cssW, 0)[0];
    for (let n = n0; n <= n1; n += ns) ctx.fillText(String(n), c.tx + n * c.s, cssH - 9);
    ctx.textAlign = "right";
    const ps = niceStep(PASS_PITCH * c.s, 24);
    const top = toWorld(c, 0, 0)[1], bot = toWorld(c, 0, cssH)[1];
    const p0 = Math.max(0, Math.ceil(bot / PASS_PITCH / ps) * ps);
    for (let p = p0; p * PASS_PITCH <= top; p += ps) {
      ctx.fillText("p" + p, 40, c.ty - (p * PASS_PITCH + 1) * c.s);
    }
  }

  // ---- hovering -------------------------------------------------------------------------------

  function pick(v, c, sx, sy) {
    const wpt = toWorld(c, sx, sy);
    const wx = wpt[0], wy = wpt[1];
    const reach = Math.min(8, Math.max(1, Math.ceil(4 / c.s)));
    const ix = Math.floor(wx), iy = Math.floor(wy);
    let best = -1, bestD = Infinity;
    const radius = Math.max(v.w / 2, 4 / c.s);
    for (let dx = -reach; dx <= reach; dx++) {
      for (let dy = -reach; dy <= reach; dy++) {
        const b = v.buckets.get(bucketKey(ix + dx, iy + dy));
        if (!b) continue;
        for (let k = 0; k < b.length; k++) {
          const i = b[k];
          const ex = Math.abs(v.x[i] - wx), ey = Math.abs(v.y[i] - wy);
          const inside = ex <= v.w / 2 && ey <= v.h / 2;
          const d = inside ? -1 : Math.hypot(ex, ey);
          if (d < bestD && (inside || d <= radius)) { best = i; bestD = d; }
        }
      }
    }
    return best;
  }

  function showTooltip(v, i, clientX, clientY) {
    const lines = v.what === "op" ? opTooltip(v.ids[i]) : stitchTooltip(v.ids[i]);
    tooltip.textContent = lines.join("\n");
    tooltip.hidden = false;
    const r = tooltip.getBoundingClientRect();
    let left = clientX + 14, top = clientY + 14;
    if (left + r.width > window.innerWidth) left = Math.max(0, clientX - r.width - 14);
    if (top + r.height > window.innerHeight) top = Math.max(0, clientY - r.height - 14);
    tooltip.style.left = left + "px";
    tooltip.style.top = top + "px";
  }

  let drag = null;
  canvas.addEventListener("mousedown", function (e) {
    drag = { x: e.clientX, y: e.clientY, moved: false };
  });
  window.addEventListener("mouseup", function () { drag = null; });
  canvas.addEventListener("mouseleave", function () {
    hover = -1;
    tooltip.hidden = true;
    drawHover();
  });
  canvas.addEventListener("mousemove", function (e) {
    const v = view();
    if (!v) return;
    const c = cam();
    if (drag && (e.buttons & 1)) {
      c.tx += e.clientX - drag.x;
      c.ty += e.clientY - drag.y;
      drag.x = e.clientX;
      drag.y = e.clientY;
      drag.moved = true;
      tooltip.hidden = true;
      redraw();
      return;
    }
    const r = canvas.getBoundingClientRect();
    const i = pick(v, c, e.clientX - r.left, e.clientY - r.top);
    if (i !== hover) { hover = i; drawHover(); }
    if (i >= 0) showTooltip(v, i, e.clientX, e.clientY);
    else tooltip.hidden = true;
  });
  canvas.addEventListener("wheel", function (e) {
    const v = view();
    if (!v) return;
    e.preventDefault();
    const c = cam();
    const r = canvas.getBoundingClientRect();
    const sx = e.clientX - r.left, sy = e.clientY - r.top;
    const f = Math.exp(-e.deltaY * (e.deltaMode === 1 ? 0.05 : 0.0015));
    const s = Math.min(400, Math.max(1e-3, c.s * f));
    const w = toWorld(c, sx, sy);
    c.s = s;
    c.tx = sx - w[0] * s;
    c.ty = sy + w[1] * s;
    tooltip.hidden = true;
    redraw();
  }, { passive: false });

  // ---- views and the legend -------------------------------------------------------------------

  const legend = document.getElementById("legend");

  function fillLegend(v) {
    legend.textContent = "";
    if (!v) return;
    v.palette.forEach(function (p, ci) {
      if (!v.groups[ci].length) return;
      const item = document.createElement("span");
      item.className = "key";
      const sw = document.createElement("i");
      sw.style.background = p.colour;
      item.appendChild(sw);
      item.appendChild(document.createTextNode(p.labels.join(" ")));
      legend.appendChild(item);
    });
    const note = document.createElement("span");
    note.className = "note";
    note.textContent = v.note;
    legend.appendChild(note);
  }

  function show(name) {
    current = name;
    hover = -1;
    tooltip.hidden = true;
    document.querySelectorAll("#tabs button").forEach(function (b) {
      b.classList.toggle("active", b.dataset.view === name);
    });
    const v = view();
    if (!v) {
      notice.textContent = "The " + name + " view needs a design (.knit): " + D.file +
        " is a Knitout program, which has no stitches, courses or wales to draw.";
      notice.hidden = false;
    } else {
      notice.hidden = true;
    }
    fillLegend(v);
    resize(); // the legend may have wrapped the bar and changed the canvas's room
    highlight = selected >= 0 ? itemsOf(D.warnings[selected], v) : [];
    draw();
  }

  document.querySelectorAll("#tabs button").forEach(function (b) {
    b.addEventListener("click", function () { show(b.dataset.view); });
    if (!ST && b.dataset.view !== "bed") {
      b.classList.add("needs-design");
      b.title = "needs a design (.knit): a Knitout program has no stitch graph";
    }
  });
  document.getElementById("fit").addEventListener("click", function () {
    const v = view();
    if (v) { cams[current] = fit(v); draw(); }
  });
  window.addEventListener("keydown", function (e) {
    if (e.target && e.target.tagName === "INPUT") return;
    if (e.key === "1") show("bed");
    else if (e.key === "2") show("chart");
    else if (e.key === "3") show("shape");
    else if (e.key === "f" && view()) { cams[current] = fit(view()); draw(); }
  });
  window.addEventListener("resize", function () { resize(); draw(); });
  if (window.ResizeObserver) {
    new ResizeObserver(function () {
      if (stage.clientWidth !== cssW || stage.clientHeight !== cssH) { resize(); draw(); }
    }).observe(stage);
  }

  // ---- warnings -------------------------------------------------------------------------------

  /* The items of view v that warning w is about: its ops on the bed (a stitch stands for
   * the op that formed its loop), its stitches in the chart and shape (an op for its stitch). */
  function itemsOf(w, v) {
    if (!v) return [];
    const out = new Set();
    function add(id) {
      const i = v.byId.get(id);
      if (i !== undefined) out.add(i);
    }
    if (v.what === "op") {
      w.ops.forEach(add);
      if (ST) w.stitches.forEach(function (s) { if (ST.op[s] >= 0) add(ST.op[s]); });
    } else {
      w.stitches.forEach(add);
      w.ops.forEach(function (op) { if (OPS.stitch[op] >= 0) add(OPS.stitch[op]); });
    }
    return Array.from(out).sort(function (a, b) { return a - b; });
  }

  function centreOn(v, items) {
    if (!items.length) return;
    let x0 = Infinity, x1 = -Infinity, y0 = Infinity, y1 = -Infinity;
    items.forEach(function (i) {
      x0 = Math.min(x0, v.x[i]); x1 = Math.max(x1, v.x[i]);
      y0 = Math.min(y0, v.y[i]); y1 = Math.max(y1, v.y[i]);
    });
    const c = cam();
    const bw = x1 - x0 + 4, bh = y1 - y0 + 4;
    const fitS = Math.min(cssW / bw, cssH / bh) * 0.8;
    c.s = Math.min(Math.max(fitS, 1e-3), Math.max(c.s, 16));
    if (fitS < c.s) c.s = fitS;
    c.tx = cssW / 2 - ((x0 + x1) / 2) * c.s;
    c.ty = cssH / 2 + ((y0 + y1) / 2) * c.s;
  }

  function selectWarning(k) {
    selected = k;
    document.querySelectorAll("#warnings li").forEach(function (li, j) {
      li.classList.toggle("selected", j === k);
    });
    const v = view();
    highlight = k >= 0 ? itemsOf(D.warnings[k], v) : [];
    if (v) centreOn(v, highlight);
    draw();
    return highlight.length;
  }

  function fillWarnings() {
    const list = document.getElementById("warnings");
    document.getElementById("warning-count").textContent = "(" + D.warnings.length + ")";
    if (!D.warnings.length) {
      const li = document.createElement("li");
      li.className = "empty";
      li.textContent = "no warnings: knitc's checks and its simulation of the program found nothing";
      list.appendChild(li);
      return;
    }
    D.warnings.forEach(function (w, k) {
      const li = document.createElement("li");
      li.className = w.severity;
      const head = document.createElement("div");
      head.className = "head";
      head.textContent = w.severity + "[" + w.code + "]" +
        (w.source === "simulation" ? " (simulation)" : "");
      li.appendChild(head);
      const msg = document.createElement("div");
      msg.textContent = w.message;
      li.appendChild(msg);
      const where = document.createElement("div");
      where.className = "where";
      const chain = w.span >= 0 ? spanChain(w.span) : [];
      const bits = chain.length ? [chain[0][0], chain[0][1] + " | " + chain[0][2].trim()] : [];
      if (w.op_text) bits.push("op " + w.ops[0] + ": " + w.op_text);
      const n = w.stitches.length, m = w.ops.length;
      // a simulation finding is at its op; a diagnostic shows what its line made or wrote
      const of = w.source === "simulation" ? "" : " of this line";
      if (n) bits.push(n + (n === 1 ? " stitch" : " stitches") + of);
      else if (m) bits.push(m + (m === 1 ? " op" : " ops") + of);
      where.textContent = bits.join("\n");
      li.appendChild(where);
      li.title = "show where it happens";
      li.addEventListener("click", function () { selectWarning(k); });
      list.appendChild(li);
    });
  }

  // ---- the page's API -------------------------------------------------------------------------

  /* Where item `id` (an "op" or a "stitch") is drawn in the current view, in CSS pixels
   * from the canvas's top left corner; null when the view does not show it. */
  function itemPixel(what, id) {
    const v = view();
    if (!v) return null;
    let i;
    if (what === v.what) i = v.byId.get(id);
    else if (what === "stitch") i = ST && ST.op[id] >= 0 ? v.byId.get(ST.op[id]) : undefined;
    else i = OPS.stitch[id] >= 0 ? v.byId.get(OPS.stitch[id]) : undefined;
    if (i === undefined) return null;
    const p = toScreen(cam(), v.x[i], v.y[i]);
    return { x: p[0], y: p[1], width: cssW, height: cssH, cell: v.w * cam().s };
  }

  /* Centre item `id` and zoom so that it is `px` pixels wide; its pixel position after. */
  function focus(what, id, px) {
    const v = view();
    const p0 = itemPixel(what, id);
    if (!v || !p0) return null;
    const c = cam();
    const w = toWorld(c, p0.x, p0.y);
    c.s = (px || 16) / v.w;
    c.tx = cssW / 2 - w[0] * c.s;
    c.ty = cssH / 2 + w[1] * c.s;
    draw();
    return itemPixel(what, id);
  }

  window.knitcViewer = {
    data: D,
    show: show,
    view: function () { return current; },
    itemPixel: itemPixel,
    focus: focus,
    selectWarning: selectWarning,
    highlighted: function () { return highlight.length; },
    colours: { kinds: KIND_COLOURS, instructions: INSTR_COLOURS, highlight: HIGHLIGHT },
    ready: false,
  };

  resize();
  fillWarnings();
  show(ST ? "chart" : "bed");
  window.knitcViewer.ready = true;
})();
