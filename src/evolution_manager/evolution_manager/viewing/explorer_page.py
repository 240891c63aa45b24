"""The explorer page's HTML, CSS and JavaScript (``explorer.write_explorer`` fills in __TITLE__ and __DATA__,
and __LIBRARY_STYLE__ and __LIBRARY_SCRIPT__ with ``LIBRARY_STYLE`` and ``LIBRARY_SCRIPT`` for a page with
``--library``, with nothing otherwise: they sit where the page had no character, so it stays as it was).

Plain JavaScript, no library: heatmaps and trees are SVG built in the page, the animation is drawn on a
canvas from the packed poses (layout: ``explorer._pack``). The page reads ``location.hash``
(``#objective=food&bin=3,4,2``) at load and on every change, and writes it when a bin is clicked.
"""

PAGE = r"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>__TITLE__</title>
<style>
body { font: 14px/1.4 system-ui, sans-serif; margin: 0; color: #222; }
header { padding: 8px 16px; background: #f3f3f3; border-bottom: 1px solid #ccc; }
header h1 { font-size: 18px; margin: 0 0 4px 0; }
button.objective, button.colour { margin-right: 4px; }
button.active { font-weight: bold; background: #dde8f7; }
main { display: flex; flex-wrap: wrap; gap: 16px; padding: 12px 16px; }
#heatmaps { display: grid; grid-template-columns: repeat(4, auto); gap: 8px 12px; align-content: start; }
.panel h3 { font-size: 12px; font-weight: normal; margin: 0; text-align: center; }
.cell { stroke: #fff; stroke-width: 1; }
.cell.empty { fill: #eee; }
.cell.filled { cursor: pointer; }
.cell.selected { stroke: #e00; stroke-width: 3; }
#legend { grid-column: 1 / span 4; font-size: 12px; }
#tooltip { position: fixed; pointer-events: none; background: #fffbe6; border: 1px solid #aaa; padding: 4px 6px;
  font-size: 12px; display: none; max-width: 420px; z-index: 2; }
#detail { flex: 1 1 520px; min-width: 0; }
#detail table { border-collapse: collapse; margin: 6px 0; }
#detail td, #detail th { border: 1px solid #ccc; padding: 2px 6px; font-size: 13px; }
.tree { margin: 6px 0 12px 0; overflow-x: auto; max-width: 100%; }
.tree code { display: block; font-size: 12px; white-space: pre-wrap; word-break: break-all; color: #333; }
.tree h4 { margin: 4px 0; font-size: 13px; }
#player { margin-top: 8px; }
#animation { border: 1px solid #999; }
.note { color: #666; font-size: 12px; }
__LIBRARY_STYLE__</style>
</head>
<body>
<header>
<h1>__TITLE__</h1>
<div id="info"></div>
<div>objective: <span id="objectives"></span> colour by: <span id="colours"></span></div>
</header>
<main>
<div id="heatmaps"></div>
<section id="detail"><p class="note">Click a bin to see its trees, values and trial.</p></section>
</main>
<div id="tooltip"></div>
<script type="application/json" id="data">__DATA__</script>
<script>
"use strict";
const DATA = JSON.parse(document.getElementById("data").textContent);
const state = { objective: null, bin: null, colour: "in-run", timer: null };
const VIRIDIS = [[68,1,84],[72,40,120],[62,74,137],[49,104,142],[38,130,142],[31,158,137],[53,183,121],
  [109,205,89],[180,222,44],[253,231,37]];
const SVGNS = "http://www.w3.org/2000/svg";

function colourOf(v) {
  const x = Math.min(1, Math.max(0, v)) * (VIRIDIS.length - 1);
  const i = Math.min(VIRIDIS.length - 2, Math.floor(x)), f = x - i;
  const c = VIRIDIS[i].map((a, k) => Math.round(a + (VIRIDIS[i + 1][k] - a) * f));
  return `rgb(${c[0]},${c[1]},${c[2]})`;
}
function el(tag, attrs, text) {
  const e = tag.startsWith("svg:") ? document.createElementNS(SVGNS, tag.slice(4)) : document.createElement(tag);
  for (const [k, v] of Object.entries(attrs || {})) e.setAttribute(k, v);
  if (text !== undefined) e.textContent = text;
  return e;
}
function fmt(v) { return v === undefined || v === null ? "-" : Number(v).toFixed(4); }
function hasHeldOut(objective) {
  return Object.values(DATA.objectives[objective].bins).some(items => items.some(i => i.held_out !== undefined));
}
function fitnessTop(grid) {
  // 1 for the objectives in [0, 1]; above it (to a quarter) when a value exceeds 1: foraging's deliveries
  let top = 0;
  for (const items of Object.values(grid.bins)) for (const i of items)
    top = Math.max(top, i.fitness, i.held_out ?? 0);
  return top <= 1 ? 1 : Math.ceil(top * 4) / 4;
}
function binValue(items) {
  if (state.colour === "held-out") {
    const h = items.map(i => i.held_out).filter(v => v !== undefined);
    return h.length ? Math.max(...h) : null;
  }
  return items[0].fitness;
}

function drawControls() {
  const objs = document.getElementById("objectives");
  objs.textContent = "";
  for (const name of Object.keys(DATA.objectives)) {
    const b = el("button", { class: "objective" + (name === state.objective ? " active" : ""), "data-objective": name },
      name + (DATA.objectives[name].evolved ? " (evolved)" : ""));
    b.onclick = () => select(name, null);
    objs.appendChild(b);
  }
  const cols = document.getElementById("colours");
  cols.textContent = "";
  const options = ["in-run"].concat(hasHeldOut(state.objective) ? ["held-out"] : []);
  if (!options.includes(state.colour)) state.colour = "in-run";
  for (const name of options) {
    const b = el("button", { class: "colour" + (name === state.colour ? " active" : "") }, name + " fitness");
    b.onclick = () => { state.colour = name; select(state.objective, state.bin); };
    cols.appendChild(b);
  }
  if (options.length === 1) cols.appendChild(el("span", { class: "note" }, " (no held-out scores in this run)"));
  const grid = DATA.objectives[state.objective];
  document.getElementById("info").textContent = `run ${DATA.run}, seed ${DATA.seed}, ` +
    `${DATA.evaluations ?? "?"} evaluations; ${state.objective}: ${Object.keys(grid.bins).length} filled bins ` +
    `of 512, coverage ${fmt(grid.coverage)}, QD score ${fmt(grid.qd_score)}`;
}

function drawHeatmaps() {
  const box = document.getElementById("heatmaps");
  box.textContent = "";
  box.setAttribute("data-objective", state.objective);
  box.setAttribute("data-colour", state.colour);
  const grid = DATA.objectives[state.objective];
  const [nx, ny, nz] = grid.shape, d = grid.descriptors, size = 22, top = fitnessTop(grid);
  for (let k = 0; k < nz; k++) {
    const panel = el("div", { class: "panel" });
    panel.appendChild(el("h3", {}, `${d[2]} bin ${k}`));
    const svg = el("svg:svg", { width: nx * size + 18, height: ny * size + 16, "data-panel": k });
    for (let i = 0; i < nx; i++) for (let j = 0; j < ny; j++) {
      const key = `${i},${j},${k}`, items = grid.bins[key];
      const rect = el("svg:rect", { x: 18 + i * size, y: (ny - 1 - j) * size, width: size, height: size,
        "data-bin": key, class: "cell " + (items ? "filled" : "empty") });
      if (items) {
        const v = binValue(items);
        rect.setAttribute("fill", v === null ? "#bbb" : colourOf(v / top));
        rect.setAttribute("data-value", v === null ? "" : v.toFixed(4));
        rect.onclick = () => select(state.objective, key);
        rect.onmousemove = ev => tooltip(ev, key, items);
        rect.onmouseleave = () => { document.getElementById("tooltip").style.display = "none"; };
        if (key === state.bin) rect.classList.add("selected");
      } else {
        rect.onmousemove = ev => tooltip(ev, key, null);
        rect.onmouseleave = () => { document.getElementById("tooltip").style.display = "none"; };
      }
      svg.appendChild(rect);
    }
    svg.appendChild(el("svg:text", { x: 18, y: ny * size + 12, "font-size": 10 }, `${d[0]} →`));
    svg.appendChild(el("svg:text", { x: 0, y: 10, "font-size": 10 }, "↑"));
    panel.appendChild(svg);
    box.appendChild(panel);
  }
  box.appendChild(el("div", { id: "legend" }, `x: ${d[0]} bin, y: ${d[1]} bin (up); colour: best ` +
    `${state.colour} fitness in the bin, 0 (purple) to ${top} (yellow); grey: not scored held-out; light: empty`));
}

function tooltip(ev, key, items) {
  const t = document.getElementById("tooltip");
  if (!items) t.textContent = `bin ${key}: empty`;
  else {
    const best = items[0];
    t.textContent = `bin ${key}: ${items.length} tree(s); best fitness ${fmt(best.fitness)}` +
      (best.held_out !== undefined ? `, held-out ${fmt(best.held_out)}` : "") +
      `; descriptors ${best.descriptors.map(fmt).join(", ")}; ${best.simplified}`;
  }
  t.style.display = "block";
  t.style.left = (ev.clientX + 14) + "px";
  t.style.top = (ev.clientY + 14) + "px";
}

// ---- trees: parse the text format, lay out leaves left to right, composites over their children
// (inner nodes: seq, sel, prob with a draw key prob@K, and the success decorator; leaves: conditions, got_food
// among them, drawn as ellipses, and actions)
function parseTree(text) {
  const tokens = text.match(/[A-Za-z_][A-Za-z0-9_]*(?:\s*@\s*[0-9]+)?|[(),]/g) || [];
  let pos = 0;
  function node() {
    const name = tokens[pos++];
    if (tokens[pos] === "(") {
      pos++;
      const children = [];
      while (true) {
        children.push(node());
        const t = tokens[pos++];
        if (t === ")") break;
      }
      const [head, key] = name.split("@").map(s => s.trim());  // prob@7: a draw key
      return { name: head.replace(/[0-9]+$/, ""), key, children };
    }
    return { name, children: [] };
  }
  return node();
}
function drawTree(text) {
  const root = parseTree(text);
  const placed = [];
  let leaf = 0;
  (function place(n, depth, parent) {
    const index = placed.length;
    placed.push({ n, depth, parent, x: 0 });
    if (n.children.length) {
      const xs = n.children.map(c => place(c, depth + 1, index));
      placed[index].x = (xs[0] + xs[xs.length - 1]) / 2;
    } else placed[index].x = leaf++;
    return placed[index].x;
  })(root, 0, null);
  const W = 92, H = 46, width = Math.max(...placed.map(p => p.x)) + 1, height = Math.max(...placed.map(p => p.depth)) + 1;
  const svg = el("svg:svg", { width: width * W, height: height * H, class: "tree-drawing",
    "data-nodes": placed.length });
  for (const p of placed) if (p.parent !== null) {
    const q = placed[p.parent];
    svg.appendChild(el("svg:line", { x1: q.x * W + W / 2, y1: q.depth * H + 30, x2: p.x * W + W / 2,
      y2: p.depth * H + 8, stroke: "#666" }));
  }
  const fill = { seq: "#cfe2f3", sel: "#fce5cd", prob: "#d9ead3", success: "#fff2cc" };
  const label = { seq: "seq →", sel: "sel ?", prob: "prob %", success: "success ✓" };
  for (const p of placed) {
    const composite = p.n.children.length > 0;
    const isCondition = !composite && !DATA.actions.includes(p.n.name);
    svg.appendChild(el("svg:rect", { x: p.x * W + 3, y: p.depth * H + 8, width: W - 6, height: 22,
      rx: isCondition ? 11 : composite ? 4 : 0, fill: composite ? fill[p.n.name] : isCondition ? "#fff" : "#eee",
      stroke: "#333" }));
    svg.appendChild(el("svg:text", { x: p.x * W + W / 2, y: p.depth * H + 23, "text-anchor": "middle",
      "font-size": 11 }, composite ? label[p.n.name] + (p.n.key !== undefined ? " @" + p.n.key : "")
        : p.n.name + (isCondition ? "?" : "")));
  }
  return svg;
}

// ---- the trial animation, from the packed frames (explorer._pack)
function unpack(anim) {
  const bytes = Uint8Array.from(atob(anim.data), c => c.charCodeAt(0));
  const F = Object.keys(DATA.objectives).length;  // the page's objectives, in its order (explorer._pack)
  const view = new DataView(bytes.buffer), n = DATA.arena.robots, rec = n * 5 + 2 * F + 2 + n + n;
  const frames = [];
  for (let off = 0; off + rec <= bytes.length; off += rec) {
    const robots = [];
    for (let i = 0; i < n; i++) {
      const o = off + i * 5;
      robots.push({ x: view.getUint16(o, true) / 10 - DATA.arena.half, y: view.getUint16(o + 2, true) / 10 - DATA.arena.half,
        h: view.getUint8(o + 4) / 256 * 2 * Math.PI });
    }
    const f = off + n * 5, fit = [...Array(F).keys()].map(k => view.getUint16(f + 2 * k, true));
    const tick = view.getUint16(f + 2 * F, true), actions = [], carrying = [];
    for (let i = 0; i < n; i++) actions.push(view.getUint8(f + 2 * F + 2 + i));
    for (let i = 0; i < n; i++) carrying.push(view.getUint8(f + 2 * F + 2 + n + i));  // bit k: food kind k + 1
    frames.push({ robots, fitness: fit.map(v => v === 65535 ? null : v / 10000), tick: tick === 65535 ? null : tick,
      actions, carrying });
  }
  return frames;
}
const COLOURS = DATA.palette.robots, REGION_COLOURS = DATA.palette.regions;
// A task's own regions (swarm_sim.model.regions): each kind's pieces in the palette's order (the food kinds,
// then the nest over them); the canvas says what it drew in data-regions.
function drawRegions(ctx, regions, S, scale, px) {
  ctx.fillStyle = DATA.palette.gap; ctx.fillRect(0, 0, S, S);
  for (const kind of Object.keys(REGION_COLOURS)) for (const p of regions) {
    if (p.kind !== kind) continue;
    ctx.fillStyle = REGION_COLOURS[kind][0];
    const [cx, cy] = px(p.x, p.y);
    if (p.shape === "disc") { ctx.beginPath(); ctx.arc(cx, cy, p.radius * scale, 0, 2 * Math.PI); ctx.fill(); }
    else if (p.shape === "beyond") {
      ctx.beginPath(); ctx.rect(0, 0, S, S); ctx.arc(cx, cy, p.radius * scale, 0, 2 * Math.PI); ctx.fill("evenodd");
    } else {
      const edge = px(0, p.shape === "above" ? p.radius : -p.radius)[1];
      if (p.shape === "above") ctx.fillRect(0, 0, S, edge); else ctx.fillRect(0, edge, S, S - edge);
    }
  }
  const drawn = Object.keys(REGION_COLOURS).flatMap(kind => regions.filter(p => p.kind === kind));
  ctx.canvas.dataset.regions = drawn.map(p => `${p.kind} ${p.shape}`).join("; ");
}
function drawFrame(canvas, anim, frames, k) {
  const ctx = canvas.getContext("2d"), S = canvas.width, A = DATA.arena, scale = S / (2 * A.half);
  const px = (x, y) => [(x + A.half) * scale, (A.half - y) * scale];
  if (anim.regions) drawRegions(ctx, anim.regions, S, scale, px);
  else {
    ctx.fillStyle = REGION_COLOURS.food[0]; ctx.fillRect(0, 0, S, S);
    ctx.beginPath(); ctx.arc(S / 2, S / 2, (A.nest_radius + anim.gap) * scale, 0, 2 * Math.PI);
    ctx.fillStyle = DATA.palette.gap; ctx.fill();
    ctx.beginPath(); ctx.arc(S / 2, S / 2, A.nest_radius * scale, 0, 2 * Math.PI);
    ctx.fillStyle = REGION_COLOURS.nest[0]; ctx.fill();
    ctx.fillStyle = REGION_COLOURS.nest[1]; ctx.font = "11px sans-serif"; ctx.fillText("nest", S / 2 - 11, S / 2 + 4);
  }
  const f = frames[k];
  ctx.lineWidth = 2;
  f.robots.forEach((r, i) => {
    ctx.strokeStyle = COLOURS[i % 9] + "88"; ctx.beginPath();
    for (let j = Math.max(0, k - 12); j <= k; j++) { const [x, y] = px(frames[j].robots[i].x, frames[j].robots[i].y);
      if (j === Math.max(0, k - 12)) ctx.moveTo(x, y); else ctx.lineTo(x, y); }
    ctx.stroke();
  });
  ctx.strokeStyle = "#9696dc"; ctx.lineWidth = 1;
  for (let i = 0; i < f.robots.length; i++) for (let j = i + 1; j < f.robots.length; j++) {
    const a = f.robots[i], b = f.robots[j];
    if (Math.hypot(a.x - b.x, a.y - b.y) <= A.range) {
      ctx.beginPath(); ctx.moveTo(...px(a.x, a.y)); ctx.lineTo(...px(b.x, b.y)); ctx.stroke(); }
  }
  const rr = Math.max(3, A.robot_radius * scale);
  f.robots.forEach((r, i) => {
    const [x, y] = px(r.x, r.y);
    DATA.palette.carry.forEach((ink, kind) => {  // carrying food: a ring per kind carried, in its ink
      if (!(f.carrying[i] >> kind & 1)) return;
      ctx.beginPath(); ctx.arc(x, y, rr + 3 + 3 * kind, 0, 2 * Math.PI); ctx.strokeStyle = ink; ctx.lineWidth = 3; ctx.stroke();
    });
    ctx.beginPath(); ctx.arc(x, y, rr, 0, 2 * Math.PI); ctx.fillStyle = COLOURS[i % 9]; ctx.fill();
    ctx.strokeStyle = "#000"; ctx.lineWidth = 2; ctx.beginPath(); ctx.moveTo(x, y);
    ctx.lineTo(x + 1.8 * rr * Math.cos(r.h), y - 1.8 * rr * Math.sin(r.h)); ctx.stroke();
    ctx.fillStyle = "#000"; ctx.fillText(String(i), x + rr + 1, y - rr);
  });
  const status = document.getElementById("frame-status");
  status.textContent = `step ${anim.steps[k]}, tick ${f.tick ?? "-"}; carrying ${f.carrying.filter(c => c).length}; fitness so far: ` +
    Object.keys(DATA.objectives).map((n, i) => `${n} ${f.fitness[i] === null ? "-" : f.fitness[i].toFixed(3)}`).join(", ") +
    "; actions: " + f.actions.map((a, i) => `${i}:${a === 255 ? "(still)" : DATA.actions[a]}`).join(" ");
  document.getElementById("frame-slider").value = k;
}

function drawDetail() {
  const box = document.getElementById("detail");
  if (state.timer) { clearInterval(state.timer); state.timer = null; }
  box.textContent = "";
  const items = state.bin && DATA.objectives[state.objective].bins[state.bin];
  box.setAttribute("data-objective", state.objective);
  box.setAttribute("data-bin", state.bin || "");
  if (!state.bin) { box.appendChild(el("p", { class: "note" }, "Click a bin to see its trees, values and trial.")); return; }
  if (!items) { box.appendChild(el("p", { class: "note", id: "empty-bin" }, `bin ${state.bin} of ${state.objective} is empty`)); return; }
  box.appendChild(el("h2", {}, `${state.objective}, bin ${state.bin} (${DATA.objectives[state.objective].descriptors.join(", ")})`));
  const table = el("table", { id: "values" });
  const head = el("tr");
  ["", "fitness", "held-out", ...DATA.objectives[state.objective].descriptors, "evaluation", "seed"].forEach(h => head.appendChild(el("th", {}, h)));
  table.appendChild(head);
  items.forEach((it, n) => {
    const row = el("tr", { class: "item", "data-fitness": it.fitness });
    const name = `tree ${n + 1}` + (it.copies > 1 ? ` (${it.copies} copies)` : "");
    [name, fmt(it.fitness), fmt(it.held_out), ...it.descriptors.map(fmt), it.evaluation ?? "-", it.seed ?? "-"]
      .forEach(v => row.appendChild(el("td", {}, String(v))));
    table.appendChild(row);
  });
  box.appendChild(table);
  const best = items[0], anim = best.animation && DATA.animations[best.animation];
  const player = el("div", { id: "player" });
  box.appendChild(player);
  if (!anim) {
    player.appendChild(el("p", { class: "note", id: "no-animation" }, "No animation stored for this bin (only the " +
      "evolved objectives' bins have one). Render it with: ws/run evolution_manager animate --tree '" + best.simplified +
      "' --seed " + best.seed + " --out trial.gif"));
    drawTrees(box, items);
    return;
  }
  const frames = unpack(anim);
  player.appendChild(el("h3", {}, `trial ${anim.trial} of seed ${anim.seed} (${anim.gap === null ? "the task's regions" : `gap ${anim.gap} mm`}), best tree of the bin`));
  const canvas = el("canvas", { id: "animation", width: 460, height: 460, "data-frames": frames.length,
    "data-tree": best.simplified });
  player.appendChild(canvas);
  const controls = el("div");
  const play = el("button", { id: "play" }, "pause");
  const slider = el("input", { id: "frame-slider", type: "range", min: 0, max: frames.length - 1, value: 0 });
  controls.append(play, slider, el("div", { id: "frame-status", class: "note" }));
  player.appendChild(controls);
  let k = 0;
  const tick = () => { drawFrame(canvas, anim, frames, k); k = (k + 1) % frames.length; };
  slider.oninput = () => { k = Number(slider.value); drawFrame(canvas, anim, frames, k); };
  play.onclick = () => {
    if (state.timer) { clearInterval(state.timer); state.timer = null; play.textContent = "play"; }
    else { state.timer = setInterval(tick, 125); play.textContent = "pause"; }
  };
  tick();
  state.timer = setInterval(tick, 125);
  drawTrees(box, items);
}

function drawTrees(box, items) {
  items.forEach((it, n) => {
    for (const [kind, text] of [["simplified", it.simplified], ["original", it.tree]]) {
      if (kind === "original" && text === it.simplified) continue;
      const div = el("div", { class: `tree ${kind}`, "data-tree": text });
      div.appendChild(el("h4", {}, `tree ${n + 1}, ${kind}` + (kind === "simplified" && text === it.tree ? " (the original is already simplest)" : "")));
      div.appendChild(drawTree(text));
      div.appendChild(el("code", {}, text));
      box.appendChild(div);
    }
    if (it.copies > 1) {
      const note = el("div", { class: "tree copies", "data-copies": it.copies });
      note.appendChild(el("h4", {}, `tree ${n + 1} stands for ${it.copies} trees of this bin that simplify to the ` +
        "same tree" + (it.copy_trees.length ? "; the others as evolved:" : " (evolved identically)")));
      it.copy_trees.forEach(t => note.appendChild(el("code", {}, t)));
      box.appendChild(note);
    }
  });
}

function render() { drawControls(); drawHeatmaps(); drawDetail(); }
function select(objective, bin) {
  state.objective = objective; state.bin = bin;
  const hash = `#objective=${objective}` + (bin ? `&bin=${bin}` : "") +
    (state.colour === "held-out" ? "&colour=held-out" : "");
  if (location.hash !== hash) history.replaceState(null, "", hash);
  render();
}
function fromHash() {
  const params = new URLSearchParams(location.hash.replace(/^#/, ""));
  const names = Object.keys(DATA.objectives);
  let objective = params.get("objective");
  if (!names.includes(objective)) objective = DATA.evolved.find(o => names.includes(o)) || names[0];
  const bin = params.get("bin");
  state.objective = objective;
  state.bin = bin && /^\d+,\d+,\d+$/.test(bin) ? bin : null;
  state.colour = params.get("colour") === "held-out" ? "held-out" : "in-run";
  render();
}
window.addEventListener("hashchange", fromHash);
fromHash();
</script>
__LIBRARY_SCRIPT__</body>
</html>
"""

LIBRARY_STYLE = """.panel.block-odd { background: #eef3fb; }
.panel.block-start { border-top: 3px solid #333; }
.block-line { stroke: #111; stroke-width: 3; pointer-events: none; }
.primitive-outline { fill: none; stroke: #f80; stroke-width: 3; pointer-events: none; }
.primitive-badge { font-size: 11px; font-weight: bold; fill: #fff; stroke: #000; stroke-width: 0.6;
  pointer-events: none; }
#library { grid-column: 1 / span 4; font-size: 12px; }
#library table { border-collapse: collapse; margin: 4px 0; }
#library td, #library th { border: 1px solid #ccc; padding: 1px 5px; }
#library-primitive { font-weight: bold; color: #a50; }
"""
"""CSS of the library view (only in pages built with ``--library``)."""

LIBRARY_SCRIPT = r"""<script>
"use strict";
// The library on the grids (explorer.library_view, DATA.library): thick lines between blocks, panels of one
// conditionality block tinted alike, this run's primitives outlined on their bins (a badge with the block
// number, the name in the tooltip and the bin's detail), other runs' primitives of the objective in a table.
// It wraps the page's drawing functions and draws again.
const LIBRARY = DATA.library;
const baseHeatmaps = drawHeatmaps, baseDetail = drawDetail, baseTooltip = tooltip;
function blockVariant(key, shape) {
  const n = LIBRARY.bins, b = key.split(",").map((v, d) => Math.floor(Number(v) * n / shape[d]));
  return b[0] * n * n + b[1] * n + b[2] + 1;  // libraries.variant
}
function primitiveAt(key) {
  const lib = LIBRARY.objectives[state.objective];
  return lib && key ? lib.here.find(p => p.bin === key) : undefined;
}
function primitiveLabel(p) { return `library primitive ${p.name} (block ${p.variant} of ${LIBRARY.blocks})`; }
drawHeatmaps = function () {
  baseHeatmaps();
  const grid = DATA.objectives[state.objective], [nx, ny, nz] = grid.shape, size = 22, n = LIBRARY.bins;
  const box = document.getElementById("heatmaps");
  box.setAttribute("data-library-blocks", LIBRARY.blocks);
  for (const svg of box.querySelectorAll("svg[data-panel]")) {
    const k = Number(svg.getAttribute("data-panel")), c = Math.floor(k * n / nz), panel = svg.parentNode;
    panel.classList.add(c % 2 ? "block-odd" : "block-even");
    panel.setAttribute("data-conditionality-block", c);
    if (k > 0 && (k * n) % nz === 0) panel.classList.add("block-start");
    if (n > 1) panel.querySelector("h3").textContent += ` (block ${grid.descriptors[2]} ${c})`;
    for (const rect of svg.querySelectorAll("rect[data-bin]")) {
      const key = rect.getAttribute("data-bin"), p = primitiveAt(key);
      rect.setAttribute("data-block", blockVariant(key, grid.shape));
      if (!p) continue;
      rect.classList.add("primitive");
      rect.setAttribute("data-primitive", p.name);
      rect.appendChild(el("svg:title", {}, primitiveLabel(p)));
      const x = Number(rect.getAttribute("x")), y = Number(rect.getAttribute("y"));
      // an outline drawn over the cells (a cell's own stroke hides under its right and lower neighbours)
      svg.appendChild(el("svg:rect", { x: x + 1.5, y: y + 1.5, width: size - 3, height: size - 3,
        class: "primitive-outline", "data-primitive": p.name }));
      svg.appendChild(el("svg:text", { x: x + size / 2, y: y + size / 2 + 4, "text-anchor": "middle",
        class: "primitive-badge", "data-primitive": p.name }, String(p.variant)));
    }
    for (let i = 1; i < n; i++) {  // block boundaries of movement (across) and rotation (up)
      const x = 18 + i * nx / n * size, y = (ny - i * ny / n) * size;
      svg.appendChild(el("svg:line", { x1: x, y1: 0, x2: x, y2: ny * size, class: "block-line", "data-axis": "0" }));
      svg.appendChild(el("svg:line", { x1: 18, y1: y, x2: 18 + nx * size, y2: y, class: "block-line", "data-axis": "1" }));
    }
  }
  const div = el("div", { id: "library", "data-blocks": LIBRARY.blocks });
  div.appendChild(el("p", {}, `library ${LIBRARY.file}: ${LIBRARY.blocks} block(s) per grid, ${n} per descriptor ` +
    "(thick lines divide movement and rotation; tinted and ruled panels, conditionality); orange outline and " +
    "number: a primitive chosen from this run, and its block"));
  const lib = LIBRARY.objectives[state.objective];
  if (!lib) { div.appendChild(el("p", { class: "note" }, `the library has no primitive of ${state.objective}`)); }
  else {
    div.appendChild(el("p", { id: "library-here" }, `${lib.family} from this run: ` + (lib.here.length ?
      lib.here.map(p => `${p.name} (bin ${p.bin})`).join(", ") : "none")));
    if (lib.other.length) {
      div.appendChild(el("h4", {}, `${lib.family} chosen from other runs, beside this run's candidate of the ` +
        "block (its tree of highest derated fitness; runs are compared by raw fitness under the paper profile, " +
        "derated under clean)"));
      const table = el("table", { id: "library-others" }), head = el("tr");
      ["name", "block", "source run", "bin", "fitness", "derated", "this run's bin", "fitness", "derated"]
        .forEach(h => head.appendChild(el("th", {}, h)));
      table.appendChild(head);
      for (const p of lib.other) {
        const row = el("tr", { class: "library-other", "data-primitive": p.name }), h = p.here;
        [p.name, `${p.variant} of ${LIBRARY.blocks}`, p.run, p.bin, fmt(p.fitness), fmt(p.derated_fitness),
          h ? h.bin : "empty", h ? fmt(h.fitness) : "-", h ? fmt(h.derated_fitness) : "-"]
          .forEach(v => row.appendChild(el("td", {}, String(v))));
        table.appendChild(row);
      }
      div.appendChild(table);
    }
  }
  box.appendChild(div);
};
drawDetail = function () {
  baseDetail();
  const p = primitiveAt(state.bin);
  if (!p) return;
  const box = document.getElementById("detail"), note = el("p", { id: "library-primitive", "data-primitive": p.name },
    primitiveLabel(p));
  const title = box.querySelector("h2");
  if (title) title.after(note); else box.prepend(note);
};
tooltip = function (ev, key, items) {
  baseTooltip(ev, key, items);
  const p = primitiveAt(key);
  if (p) document.getElementById("tooltip").textContent += "; " + primitiveLabel(p);
};
render();
</script>
"""
"""JavaScript of the library view (only in pages built with ``--library``), run after the page's own."""


def _section(start: str, end: str) -> str:
    """The part of the tree page's script from ``start`` up to ``end``: what the swarm page shares with it,
    taken from it so that the two never drift apart (and the tree page stays byte for byte as it was)."""
    return PAGE[PAGE.index(start) : PAGE.index(end)]


SHARED_SCRIPT = _section("const VIRIDIS", "function hasHeldOut") + _section(
    "// ---- trees:", "function drawDetail"
)
"""The tree page's colour scale, element and number helpers, tree drawing and trial animation (unpacking
``explorer_parts.pack``'s bytes, drawing a frame with robot ``i`` in ``COLOURS[i]``), which the swarm page
runs as they are."""

SWARM_PAGE = r"""<!DOCTYPE html>
<html lang="en">
<head>
<meta charset="utf-8">
<title>__TITLE__</title>
<style>
body { font: 14px/1.4 system-ui, sans-serif; margin: 0; color: #222; }
header { padding: 8px 16px; background: #f3f3f3; border-bottom: 1px solid #ccc; }
header h1 { font-size: 18px; margin: 0 0 4px 0; }
button.swarm { margin-right: 4px; }
button.active { font-weight: bold; background: #dde8f7; }
main { display: flex; flex-wrap: wrap; gap: 16px; padding: 12px 16px; }
#heatmaps { display: grid; grid-template-columns: repeat(4, auto); gap: 8px 12px; align-content: start; }
.panel h3 { font-size: 12px; font-weight: normal; margin: 0; text-align: center; }
.cell { stroke: #fff; stroke-width: 1; }
.cell.empty { fill: #eee; }
.cell.filled { cursor: pointer; }
.cell.selected { stroke: #e00; stroke-width: 3; }
#legend, #no-grid { grid-column: 1 / span 4; font-size: 12px; max-width: 760px; }
#tooltip { position: fixed; pointer-events: none; background: #fffbe6; border: 1px solid #aaa; padding: 4px 6px;
  font-size: 12px; display: none; max-width: 420px; z-index: 2; }
#detail { flex: 1 1 520px; min-width: 0; }
#detail table { border-collapse: collapse; margin: 6px 0; }
#detail td, #detail th { border: 1px solid #ccc; padding: 2px 6px; font-size: 13px; }
.mark { display: inline-block; background: #ffe08a; border: 1px solid #c90; padding: 0 6px; font-size: 12px;
  margin-left: 8px; vertical-align: middle; }
.swatch { display: inline-block; width: 14px; height: 14px; border: 1px solid #333; border-radius: 7px;
  vertical-align: middle; margin-right: 4px; }
#swarm-legend div { margin: 2px 0; font-size: 13px; }
.tree { margin: 6px 0 12px 0; overflow-x: auto; max-width: 100%; }
.tree code { display: block; font-size: 12px; white-space: pre-wrap; word-break: break-all; color: #333; }
.tree h4 { margin: 4px 0; font-size: 13px; }
#player { margin-top: 8px; }
#animation { border: 1px solid #999; }
.note { color: #666; font-size: 12px; }
</style>
</head>
<body>
<header>
<h1>__TITLE__</h1>
<div id="info"></div>
<div>marked swarms: <span id="swarms"></span></div>
</header>
<main>
<div id="heatmaps"></div>
<section id="detail"><p class="note">Click a bin or a marked swarm to see its trees, values and trial.</p></section>
</main>
<div id="tooltip"></div>
<script type="application/json" id="data">__DATA__</script>
<script>
"use strict";
const DATA = JSON.parse(document.getElementById("data").textContent);
const state = { swarm: null, bin: null, timer: null };
__SHARED_SCRIPT__
// ---- the swarm page (swarm_explorer): a composition run's grid and marked swarms, or a team run's teams
const GROUP_COLOURS = COLOURS.slice();  // tree k of a swarm in colour k; drawFrame draws robot i in COLOURS[i]
const LETTERS = "ABCDEFGHIJKLMNOPQRSTUVWXYZ";
const TEAM = DATA.kind === "teams";
const MARKS = { best: TEAM ? "best team" : "best swarm", validated: "validated choice",
  homogeneous: "homogeneous baseline", "homogeneous-validated": "homogeneous baseline, validated" };
function letter(g) { return LETTERS[g % 26] + (g >= 26 ? String(Math.floor(g / 26)) : ""); }
function groupColour(g) { return GROUP_COLOURS[g % GROUP_COLOURS.length]; }
function range(grid) {
  const v = Object.values(grid.bins).map(s => s.fitness).filter(x => x !== null && x !== undefined);
  const lo = Math.min(0, ...v), hi = Math.max(lo + 1e-9, ...v);  // 0 (or below) to the grid's best
  return [lo, hi];
}

function drawControls() {
  const box = document.getElementById("swarms");
  box.textContent = "";
  for (const name of Object.keys(DATA.marked)) {
    const b = el("button", { class: "swarm" + (name === state.swarm ? " active" : ""), "data-swarm": name }, MARKS[name] || name);
    b.onclick = () => select(name, null);
    box.appendChild(b);
  }
  if (!Object.keys(DATA.marked).length) box.appendChild(el("span", { class: "note" }, "none (the run has no summary.json yet)"));
  const parts = [`run ${DATA.run} (${DATA.label}), seed ${DATA.seed}, scenario seed ${DATA.scenario_seed}`,
    `${DATA.evaluations ?? "?"} evaluations${DATA.finished === false ? " (not finished)" : ""}`,
    `task ${DATA.task}, objective ${DATA.objective}`];
  if (TEAM) parts.push(`${DATA.team} sub-group(s): robot i runs tree i mod ${DATA.team}`);
  else {
    parts.push(`${DATA.cells.length} cells from ${DATA.sources.join(", ")}`);
    const g = DATA.grid;
    parts.push(`grid by ${DATA.axes.join(", ")}: ${Object.keys(g.bins).length} filled bins of 512` +
      (g.coverage !== null && g.coverage !== undefined ? `, coverage ${fmt(g.coverage)}, QD score ${fmt(g.qd_score)}` : ""));
    if (g.qd_scores) parts.push("QD score at " + Object.entries(g.qd_scores).map(([k, v]) => `${k}: ${fmt(v)}`).join(", ") + " bins per axis");
  }
  document.getElementById("info").textContent = parts.join("; ");
}

function drawHeatmaps() {
  const box = document.getElementById("heatmaps");
  box.textContent = "";
  const grid = DATA.grid;
  if (!grid) {
    box.appendChild(el("p", { id: "no-grid", class: "note" }, "A team run has no grid: it evolves one team of " +
      `${DATA.team} tree(s) at a time, kept by fitness alone (no behaviour space bins it). Its best team and validated ` +
      "choice are the marked swarms above."));
    return;
  }
  box.setAttribute("data-source", grid.source);
  const [nx, ny, nz] = grid.shape, d = DATA.axes, size = 22, [lo, hi] = range(grid);
  for (let k = 0; k < nz; k++) {
    const panel = el("div", { class: "panel" });
    panel.appendChild(el("h3", {}, `${d[2]} bin ${k}`));
    const svg = el("svg:svg", { width: nx * size + 18, height: ny * size + 16, "data-panel": k });
    for (let i = 0; i < nx; i++) for (let j = 0; j < ny; j++) {
      const key = `${i},${j},${k}`, swarm = grid.bins[key];
      const rect = el("svg:rect", { x: 18 + i * size, y: (ny - 1 - j) * size, width: size, height: size,
        "data-bin": key, class: "cell " + (swarm ? "filled" : "empty") });
      if (swarm) {
        rect.setAttribute("fill", colourOf((swarm.fitness - lo) / (hi - lo)));
        rect.setAttribute("data-value", swarm.fitness.toFixed(4));
        rect.onclick = () => select(null, key);
        if (key === state.bin) rect.classList.add("selected");
      }
      rect.onmousemove = ev => tooltip(ev, key, swarm);
      rect.onmouseleave = () => { document.getElementById("tooltip").style.display = "none"; };
      svg.appendChild(rect);
    }
    svg.appendChild(el("svg:text", { x: 18, y: ny * size + 12, "font-size": 10 }, `${d[0]} →`));
    svg.appendChild(el("svg:text", { x: 0, y: 10, "font-size": 10 }, "↑"));
    panel.appendChild(svg);
    box.appendChild(panel);
  }
  const what = grid.source === "archive" ? "MAP-Elites' archive (one composition per bin)" :
    "every evaluated composition binned by the run's behaviour space, the fittest of each bin (the run keeps no archive)";
  box.appendChild(el("div", { id: "legend" }, `${what}; x: ${d[0]} bin, y: ${d[1]} bin (up), panels: ${d[2]}; ` +
    `colour: in-run ${DATA.objective}, ${fmt(lo)} (purple) to ${fmt(hi)} (yellow); light: empty. The run's files hold ` +
    "no held-out score per bin: the marked swarms above carry theirs."));
}

function tooltip(ev, key, swarm) {
  const t = document.getElementById("tooltip");
  t.textContent = !swarm ? `bin ${key}: empty` : `bin ${key}: fitness ${fmt(swarm.fitness)}; ` +
    (swarm.values ? DATA.axes.map((a, i) => `${a} ${fmt(swarm.values[i])}`).join(", ") + "; " : "") +
    `${swarm.groups.length} distinct tree(s)`;
  t.style.display = "block";
  t.style.left = (ev.clientX + 14) + "px";
  t.style.top = (ev.clientY + 14) + "px";
}

function groupText(s, g, n) {
  const robots = `robot${g.robots.length > 1 ? "s" : ""} ${g.robots.join(", ")}`;
  if (TEAM) {
    const sub = [...new Set(g.robots.map(r => s.subgroups[r]))];
    return `tree ${letter(n)} (sub-group${sub.length > 1 ? "s" : ""} ${sub.join(", ")}): ${robots}`;
  }
  const cells = [...new Set(g.robots.map(r => s.cells[r]))].map(k => DATA.cells[k]);
  return `tree ${letter(n)}: ${robots}; repertoire cell${cells.length > 1 ? "s" : ""} ` +
    cells.map(c => `${c.index} (run ${c.source}, ${c.objective} bin ${c.bin}, fitness ${fmt(c.fitness)})`).join(", ");
}

function drawDetail() {
  const box = document.getElementById("detail");
  if (state.timer) { clearInterval(state.timer); state.timer = null; }
  box.textContent = "";
  box.setAttribute("data-swarm", state.swarm || "");
  box.setAttribute("data-bin", state.bin || "");
  const s = state.swarm ? DATA.marked[state.swarm] : state.bin && DATA.grid ? DATA.grid.bins[state.bin] : null;
  if (!state.swarm && !state.bin) { box.appendChild(el("p", { class: "note" }, "Click a bin or a marked swarm to see its trees, values and trial.")); return; }
  if (!s) { box.appendChild(el("p", { class: "note", id: "empty-bin" }, state.swarm ? `the run has no ${state.swarm} swarm` : `bin ${state.bin} is empty`)); return; }
  const h2 = el("h2", {}, state.swarm ? s.title : `bin ${state.bin} (${DATA.axes.join(", ")})`);
  if (state.swarm) h2.appendChild(el("span", { class: "mark", id: "mark" }, MARKS[state.swarm] || state.swarm));
  box.appendChild(h2);
  const table = el("table", { id: "values" }), head = el("tr");
  ["", "in-run", "held-out", "validation"].forEach(h => head.appendChild(el("th", {}, h)));
  table.appendChild(head);
  const row = (name, ...cells) => { const r = el("tr", { "data-name": name }); [name, ...cells].forEach(v => r.appendChild(el("td", {}, String(v)))); table.appendChild(r); };
  row(`fitness (${DATA.objective})`, fmt(s.fitness), fmt(s.held_out), fmt(s.validation_fitness));
  DATA.axes.forEach((a, i) => row(a, fmt(s.values ? s.values[i] : null), fmt(s.held_out_values ? s.held_out_values[i] : null), "-"));
  if (s.held_out_objectives) for (const [o, v] of Object.entries(s.held_out_objectives))
    if (!DATA.axes.includes(o) && o !== DATA.objective) row(o, "-", fmt(v), "-");
  row("evaluation", s.evaluation ?? "-", "", "");
  row("seed of the trial shown", s.seed, "", "");
  box.appendChild(table);
  const legend = el("div", { id: "swarm-legend" });
  legend.appendChild(el("h3", {}, "robots by the tree they run (their colour in the trial)"));
  s.groups.forEach((g, n) => {
    const line = el("div", { class: "group", "data-group": n, "data-robots": g.robots.join(","), "data-colour": groupColour(n) });
    line.appendChild(el("span", { class: "swatch", style: `background:${groupColour(n)}` }));
    line.appendChild(document.createTextNode(groupText(s, g, n)));
    legend.appendChild(line);
  });
  box.appendChild(legend);
  const robotTable = el("table", { id: "robots" }), rh = el("tr");
  ["robot", "tree", TEAM ? "sub-group" : "cell"].forEach(h => rh.appendChild(el("th", {}, h)));
  robotTable.appendChild(rh);
  s.robots.forEach((g, i) => {
    const r = el("tr", { class: "robot", "data-robot": i, "data-tree": DATA.trees[s.groups[g].tree].simplified });
    [String(i), letter(g), TEAM ? s.subgroups[i] : s.cells[i]].forEach(v => r.appendChild(el("td", {}, String(v))));
    robotTable.appendChild(r);
  });
  box.appendChild(robotTable);
  const anim = s.animation && DATA.animations[s.animation];
  const player = el("div", { id: "player" });
  box.appendChild(player);
  if (!anim) player.appendChild(el("p", { class: "note", id: "no-animation" }, Object.keys(DATA.animations).length ?
    `No animation stored for this bin: the page keeps the marked swarms' trials and the fittest bins' up to ` +
    `${DATA.animation_bytes / 1e6} MB of poses. Its trees are below; the seed of its trial is ${s.seed}.` :
    "No animation stored (the page was built with --no-animations)."));
  else {
    const colours = s.robots.map(groupColour);
    COLOURS.splice(0, COLOURS.length, ...colours);
    const frames = unpack(anim);
    player.appendChild(el("h3", {}, `trial ${anim.trial} of seed ${anim.seed} (${anim.gap === null ? "the task's regions" : `gap ${anim.gap} mm`}); robots coloured by their tree`));
    const canvas = el("canvas", { id: "animation", width: 460, height: 460, "data-frames": frames.length,
      "data-robot-colours": colours.join(",") });
    player.appendChild(canvas);
    const controls = el("div");
    const play = el("button", { id: "play" }, "pause");
    const slider = el("input", { id: "frame-slider", type: "range", min: 0, max: frames.length - 1, value: 0 });
    controls.append(play, slider, el("div", { id: "frame-status", class: "note" }));
    player.appendChild(controls);
    let k = 0;
    const draw = j => { drawFrame(canvas, anim, frames, j); canvas.setAttribute("data-drawn", j); };
    const tick = () => { draw(k); k = (k + 1) % frames.length; };
    slider.oninput = () => { k = Number(slider.value); draw(k); };
    play.onclick = () => {
      if (state.timer) { clearInterval(state.timer); state.timer = null; play.textContent = "play"; }
      else { state.timer = setInterval(tick, 125); play.textContent = "pause"; }
    };
    tick();
    state.timer = setInterval(tick, 125);
  }
  s.groups.forEach((g, n) => {
    const t = DATA.trees[g.tree];
    for (const [kind, text] of [["simplified", t.simplified], ["original", t.tree]]) {
      if (kind === "original" && text === t.simplified) continue;
      const div = el("div", { class: `tree ${kind}`, "data-tree": text, "data-group": n });
      div.appendChild(el("h4", {}, `${groupText(s, g, n)}; ${kind}` + (kind === "simplified" && text === t.tree ? " (the original is already simplest)" : "")));
      div.appendChild(drawTree(text));
      div.appendChild(el("code", {}, text));
      box.appendChild(div);
    }
  });
}

function render() { drawControls(); drawHeatmaps(); drawDetail(); }
function select(swarm, bin) {
  state.swarm = swarm; state.bin = bin;
  const hash = swarm ? `#swarm=${swarm}` : bin ? `#bin=${bin}` : "";
  if (location.hash !== hash) history.replaceState(null, "", hash || location.pathname);
  render();
}
function fromHash() {
  const params = new URLSearchParams(location.hash.replace(/^#/, ""));
  const swarm = params.get("swarm"), bin = params.get("bin");
  state.swarm = swarm && DATA.marked[swarm] ? swarm : null;
  state.bin = !state.swarm && bin && /^\d+,\d+,\d+$/.test(bin) ? bin : null;
  if (!state.swarm && !state.bin && !location.hash && DATA.marked.best) state.swarm = "best";
  render();
}
window.addEventListener("hashchange", fromHash);
fromHash();
</script>
</body>
</html>
""".replace("__SHARED_SCRIPT__", SHARED_SCRIPT)
"""The swarm page (``swarm_explorer``; ``__TITLE__`` and ``__DATA__`` filled in as the tree page's): the grid of
a composition run (or a note that a team run has none), its marked swarms, and a swarm's values, robots by
tree (a legend in the trial's colours), trees and trial. ``#swarm=best`` or ``#bin=3,4,2`` opens one."""
