// The monitor page: one WebSocket brings the tick log's records (live as they are written, or a whole log to
// replay), the first causes and the world; the page keeps the run in a RunState and shows it after one tick.
// A page that joins a long live run late gets a snapshot of the state before the server's window first.

import { RunState } from "./state.js";
import { TreeView } from "./tree.js";
import { WorldView } from "./world.js";
import { Timeline } from "./timeline.js";

const $ = (id) => document.getElementById(id);
const state = new RunState();
let mode = "live";
let causes = null;
let shownTick = 0;
let frameRequested = false;
let following = true; // live: show the newest tick

const tree = new TreeView($("tree"), $("tree-inner"), state, { onSelect: showDetails });
const world = new WorldView($("world"), $("world-legend"));
const timeline = new Timeline(state, { seek: (tick) => { following = false; showTick(tick); } });

function handle(message) {
  switch (message.type) {
    case "mode":
      mode = message.mode;
      $("mode").textContent = mode === "live" ? "live" : "replay";
      document.title = `pegbt monitor — ${message.log}`;
      $("timeline").hidden = mode !== "replay";
      break;
    case "header":
      state.setHeader(message);
      state.countChildren();
      $("tree-file").textContent = message.tree;
      tree.build();
      break;
    case "snapshot":
      state.setBase(message);
      break;
    case "tick": case "halt": case "crash": case "end":
      state.push(message);
      if (message.type === "end") {
        $("outcome").textContent = message.outcome;
        $("outcome").className = `pill ${message.outcome}`;
      }
      break;
    case "causes":
      causes = message;
      markCauses();
      break;
    case "scene":
      world.setScene(message);
      break;
    case "world":
      world.addSample(message);
      break;
  }
}

function markCauses() {
  const marks = new Map();
  for (const given of causes.given_up) marks.set(given.node, "gave up: first cause");
  const banner = $("cause-banner");
  if (causes.first) {
    const first = causes.first;
    marks.set(first.node, "first cause");
    banner.hidden = false;
    banner.textContent = `first cause (pegbt log why): ${first.path} at t=${first.t.toFixed(3)} s, tick ${first.n}: ${first.feedback || "no feedback"}`;
    banner.onclick = () => { following = false; showTick(first.n); tree.reveal(first.node); };
    $("first-cause").hidden = false;
  }
  timeline.setCauses(causes);
  tree.setCauses(marks);
}

function showTick(tick) {
  shownTick = Math.max(0, Math.min(tick, state.lastTick));
  const changed = state.seekEvents(state.eventsUpTo(shownTick));
  tree.update(changed);
  world.showTick(shownTick);
  timeline.show(shownTick);
  $("tick").textContent = shownTick;
  $("tick-total").textContent = mode === "replay" ? ` / ${state.lastTick}` : "";
  $("clock").textContent = (mode === "replay" ? state.timeOfApplied() : state.lastTime).toFixed(3);
  showRunning();
  showBlackboard();
  if (tree.selected !== null) showDetails(tree.selected);
}

function showRunning() {
  const running = state.nodes.filter((node) => state.status[node.id] === "RUNNING");
  const leaves = running.filter((node) => state.isLeaf(node.id));
  $("running-count").textContent = `(${leaves.length} leaves, ${running.length} nodes)`;
  const list = $("running");
  list.replaceChildren(
    ...leaves.map((node) => {
      const item = document.createElement("li");
      item.dataset.id = node.id;
      item.textContent = node.path + (state.feedback[node.id] ? ` — ${state.feedback[node.id]}` : "");
      item.onclick = () => tree.reveal(node.id);
      return item;
    }),
  );
}

function showBlackboard() {
  const rows = [...state.blackboard.entries()].sort(([a], [b]) => a.localeCompare(b));
  for (const key of state.changedKeys) if (!state.blackboard.has(key)) rows.push([key, "(unset)"]);
  $("blackboard").replaceChildren(
    ...rows.map(([key, value]) => {
      const row = document.createElement("tr");
      row.className = state.changedKeys.has(key) ? "changed" : "";
      const name = document.createElement("td");
      name.className = "key";
      name.textContent = key;
      const shown = document.createElement("td");
      const text = typeof value === "string" ? value : JSON.stringify(value);
      shown.textContent = text.length > 240 ? `${text.slice(0, 240)}…` : text;
      row.append(name, shown);
      return row;
    }),
  );
}

function showDetails(id) {
  const node = state.nodes[id];
  const fields = [
    ["path", node.path],
    ["type", `${node.type} (${node.class})`],
    ["source", node.source],
    ["status", state.status[id]],
    ["feedback", state.feedback[id] || "—"],
    ["params", JSON.stringify(node.params)],
    ["reads", node.reads.join(", ") || "—"],
    ["writes", node.writes.join(", ") || "—"],
  ];
  if (node.subtree) fields.push(["subtree", node.subtree]);
  const list = document.createElement("dl");
  for (const [name, value] of fields) {
    const term = document.createElement("dt");
    term.textContent = name;
    const detail = document.createElement("dd");
    detail.textContent = value;
    if (name === "source") detail.className = "source";
    list.append(term, detail);
  }
  $("details").replaceChildren(list);
}

function frame() {
  frameRequested = false;
  if (!state.header) return;
  if (mode === "live" || following) showTick(state.lastTick);
  else showTick(shownTick);
  if (monitor.loadedAt === null) monitor.loadedAt = performance.now(); // ms since navigation began
}

function connect() {
  // The run is sent only to a page that shows the token the monitor printed in its URL (`?token=…`).
  const token = new URLSearchParams(location.search).get("token");
  const query = token === null ? "" : `?token=${encodeURIComponent(token)}`;
  const socket = new WebSocket(`ws://${location.host}/ws${query}`);
  socket.onmessage = (event) => {
    for (const message of JSON.parse(event.data)) handle(message);
    if (!frameRequested) { frameRequested = true; requestAnimationFrame(frame); }
  };
  socket.onclose = () => { $("mode").textContent = `${mode} (disconnected)`; };
}

let matches = [], matchIndex = -1;
$("search").addEventListener("input", (event) => {
  matches = tree.search(event.target.value);
  matchIndex = -1;
  $("search-count").textContent = event.target.value ? `${matches.length} found` : "";
});
$("search").addEventListener("keydown", (event) => {
  if (event.key === "Enter" && matches.length) {
    matchIndex = (matchIndex + 1) % matches.length;
    tree.reveal(matches[matchIndex]);
    $("search-count").textContent = `${matchIndex + 1} of ${matches.length}`;
  }
});
$("fold").onclick = () => tree.foldSubtrees();
$("unfold").onclick = () => tree.unfoldAll();
$("first-failure").onclick = () => {
  const failure = state.firstFailure();
  if (failure) { timeline.seek(failure.n); tree.reveal(failure.node); }
};
$("first-cause").onclick = () => { if (causes && causes.first) { timeline.seek(causes.first.n); tree.reveal(causes.first.node); } };

const monitor = { state, tree, showTick, loadedAt: null, get shownTick() { return shownTick; } };
window.pegbtMonitor = monitor; // for the browser tests and the console
connect();
