// The tree as an indented list: d3-hierarchy gives the hierarchy and the visible order (pre-order, folded
// nodes keep their children aside), @tanstack/virtual-core keeps only the rows in view in the document, so a
// tree of thousands of nodes costs the rows on screen. A status change touches only the rows it concerns.

import { stratify } from "d3-hierarchy";
import { Virtualizer, elementScroll, observeElementOffset, observeElementRect } from "@tanstack/virtual-core";

const ROW_HEIGHT = 22;
const INDENT = 14;

export class TreeView {
  constructor(scroller, inner, state, { onSelect }) {
    this.scroller = scroller;
    this.inner = inner;
    this.state = state;
    this.onSelect = onSelect;
    this.rows = [];
    this.rendered = new Map(); // node id -> row element in the document
    this.selected = null;
    this.causes = new Map(); // node id -> badge text
    this.causeAncestors = new Set(); // nodes with a marked cause below them (shown when folded)
    this.matches = new Set();
    this.virtualizer = new Virtualizer({
      count: 0,
      getScrollElement: () => this.scroller,
      estimateSize: () => ROW_HEIGHT,
      overscan: 12,
      observeElementRect,
      observeElementOffset,
      scrollToFn: elementScroll,
      onChange: () => this.renderRows(),
    });
    this.cleanup = this.virtualizer._didMount();
  }

  build() {
    this.root = stratify()
      .id((node) => String(node.id))
      .parentId((node) => (node.parent === null ? null : String(node.parent)))(this.state.nodes);
    this.byId = new Array(this.state.nodes.length);
    this.sizes = this.state.nodes.map(() => 1); // nodes in each node's subtree (a parent's id is below its children's)
    for (let id = this.sizes.length - 1; id > 0; id--) this.sizes[this.state.nodes[id].parent] += this.sizes[id];
    this.root.each((node) => {
      this.byId[node.data.id] = node;
      node.hidden = null; // the children of a folded node
    });
    this.relayout();
  }

  relayout() {
    this.rows = [];
    this.root.eachBefore((node) => this.rows.push(node));
    this.index = new Map(this.rows.map((node, i) => [node.data.id, i]));
    this.virtualizer.setOptions({ ...this.virtualizer.options, count: this.rows.length });
    this.inner.style.height = `${this.rows.length * ROW_HEIGHT}px`;
    this.virtualizer._willUpdate();
    for (const element of this.rendered.values()) element.remove();
    this.rendered.clear();
    this.renderRows();
  }

  fold(node) {
    if (node.children) {
      node.hidden = node.children;
      node.children = undefined;
    }
  }

  unfold(node) {
    if (node.hidden) {
      node.children = node.hidden;
      node.hidden = null;
    }
  }

  toggle(id) {
    const node = this.byId[id];
    if (node.children) this.fold(node); else this.unfold(node);
    this.relayout();
  }

  foldSubtrees() {
    this.unfoldAll(false);
    this.root.each((node) => { if (node.data.subtree && node.depth > 0) this.fold(node); });
    this.relayout();
  }

  unfoldAll(layout = true) {
    const stack = [this.root];
    while (stack.length) {
      const node = stack.pop();
      this.unfold(node);
      if (node.children) stack.push(...node.children);
    }
    if (layout) this.relayout();
  }

  // Unfold the ancestors of `id`, scroll to it and select it.
  reveal(id, select = true) {
    let changed = false;
    for (const ancestor of this.byId[id].ancestors().slice(1)) {
      if (ancestor.hidden) { this.unfold(ancestor); changed = true; }
    }
    if (changed) this.relayout();
    this.virtualizer.scrollToIndex(this.index.get(id), { align: "center" });
    if (select) this.select(id);
    this.renderRows();
  }

  select(id) {
    this.selected = id;
    for (const [other, element] of this.rendered) element.classList.toggle("selected", other === id);
    this.onSelect(id);
  }

  renderRows() {
    if (!this.rows.length) return;
    const wanted = new Set();
    for (const item of this.virtualizer.getVirtualItems()) {
      const node = this.rows[item.index];
      if (!node) continue;
      const id = node.data.id;
      wanted.add(id);
      let element = this.rendered.get(id);
      if (!element) {
        element = this.makeRow(node);
        this.rendered.set(id, element);
        this.inner.appendChild(element);
      }
      element.style.transform = `translateY(${item.start}px)`;
    }
    for (const [id, element] of this.rendered) {
      if (!wanted.has(id)) { element.remove(); this.rendered.delete(id); }
    }
  }

  makeRow(node) {
    const id = node.data.id;
    const element = document.createElement("div");
    element.className = "row";
    element.dataset.id = id;
    element.style.paddingLeft = `${4 + node.depth * INDENT}px`;
    const toggle = document.createElement("span");
    toggle.className = "toggle";
    toggle.textContent = node.children ? "▾" : node.hidden ? "▸" : "";
    if (node.children || node.hidden) {
      toggle.addEventListener("click", (event) => { event.stopPropagation(); this.toggle(id); });
    }
    element.append(toggle);
    element.insertAdjacentHTML(
      "beforeend",
      '<span class="dot"></span><span class="name"></span><span class="type"></span><span class="fb"></span>',
    );
    element.querySelector(".name").textContent = node.data.name;
    element.querySelector(".type").textContent = node.data.type;
    if (node.data.subtree) {
      const tag = document.createElement("span");
      tag.className = "sub";
      tag.textContent = `subtree ${node.data.subtree}`;
      tag.title = tag.textContent;
      element.querySelector(".type").after(tag);
    }
    if (node.hidden) {
      const folded = document.createElement("span");
      folded.className = "folded";
      folded.textContent = `(${this.sizes[id] - 1} nodes folded)`;
      element.querySelector(".type").after(folded);
    }
    element.addEventListener("click", () => this.select(id));
    this.paint(element, id);
    return element;
  }

  paint(element, id) {
    const status = this.state.status[id] || "INVALID";
    element.dataset.status = status;
    element.querySelector(".dot").className = `dot s-${status}`;
    element.querySelector(".fb").textContent = this.state.feedback[id] ? `— ${this.state.feedback[id]}` : "";
    element.classList.toggle("selected", this.selected === id);
    element.classList.toggle("match", this.matches.has(id));
    element.classList.toggle("cause", this.causes.has(id));
    const old = element.querySelector(".badge");
    if (old) old.remove();
    const folded = this.byId[id].hidden && this.causeAncestors.has(id);
    if (this.causes.has(id) || folded) {
      const badge = document.createElement("span");
      badge.className = "badge";
      badge.textContent = this.causes.get(id) || "a cause inside";
      element.querySelector(".type").after(badge);
    }
  }

  // Repaint the rows on screen of the nodes that changed; rows off screen are painted when they scroll in.
  update(changed) {
    for (const id of changed) {
      const element = this.rendered.get(id);
      if (element) this.paint(element, id);
    }
  }

  setCauses(causes) {
    this.causes = causes;
    this.causeAncestors = new Set();
    for (const id of causes.keys()) {
      for (const ancestor of this.byId[id].ancestors().slice(1)) this.causeAncestors.add(ancestor.data.id);
    }
    this.repaintAll();
  }

  repaintAll() {
    for (const [id, element] of this.rendered) this.paint(element, id);
  }

  search(text) {
    const query = text.trim().toLowerCase();
    this.matches = new Set();
    if (query) {
      for (const node of this.state.nodes) {
        if (node.name.toLowerCase().includes(query) || node.path.toLowerCase().includes(query)) this.matches.add(node.id);
      }
    }
    this.repaintAll();
    return [...this.matches];
  }
}
