// The run as the page knows it: the tick log's header and events, and every node's status after a chosen
// tick, computed as `pegbt log replay --tick N` does (every change of every record with n <= N, in order).

export const STATUSES = ["INVALID", "RUNNING", "SUCCESS", "FAILURE"];

export class RunState {
  constructor() {
    this.header = null;
    this.nodes = [];
    this.events = []; // tick, halt, crash and end records, in order
    this.applied = 0; // how many events the statuses below include
    this.status = [];
    this.feedback = [];
    this.blackboard = new Map();
    this.changedKeys = new Set();
    this.base = null; // a late page's snapshot: the state after the records the server no longer keeps
  }

  setHeader(header) {
    this.header = header;
    this.nodes = header.nodes;
    this.events = [];
    this.base = null;
    this.reset();
  }

  setBase(snapshot) {
    this.base = snapshot;
    this.events = [];
    this.reset();
  }

  reset() {
    this.applied = 0;
    if (this.base) {
      this.status = this.base.status.slice();
      this.feedback = this.base.feedback.slice();
      this.blackboard = new Map(Object.entries(this.base.blackboard));
      return;
    }
    this.status = this.nodes.map(() => "INVALID");
    this.feedback = this.nodes.map(() => "");
    this.blackboard = new Map(Object.entries(this.header ? this.header.blackboard || {} : {}));
  }

  push(record) {
    this.events.push(record);
  }

  get lastTick() {
    if (this.events.length) return this.events[this.events.length - 1].n;
    return this.base ? this.base.n : 0;
  }

  get lastTime() {
    if (this.events.length) return this.events[this.events.length - 1].t;
    return this.base ? this.base.t : 0;
  }

  // How many events have n <= tick (events are in tick order).
  eventsUpTo(tick) {
    let low = 0, high = this.events.length;
    while (low < high) {
      const mid = (low + high) >> 1;
      if (this.events[mid].n <= tick) low = mid + 1; else high = mid;
    }
    return low;
  }

  // The tick `pegbt log replay --time T` shows: the last tick with a status change at or before T.
  tickAtTime(time) {
    let tick = 0;
    for (const event of this.events) {
      if (event.t > time) break;
      if (event.changes && event.changes.length) tick = event.n;
    }
    return tick;
  }

  // Apply events until `count` are applied (replaying from the start when going back); returns the ids
  // of the nodes whose status or feedback differ from before.
  seekEvents(count) {
    const beforeStatus = this.status.slice();
    const beforeFeedback = this.feedback.slice();
    if (count < this.applied) this.reset();
    for (let i = this.applied; i < count; i++) this.apply(this.events[i]);
    this.applied = count;
    const tick = count ? this.events[count - 1].n : 0;
    this.changedKeys = new Set();
    for (let i = count - 1; i >= 0 && this.events[i].n === tick; i--) {
      for (const key of Object.keys(this.events[i].bb || {})) this.changedKeys.add(key);
      for (const key of this.events[i].bb_unset || []) this.changedKeys.add(key);
    }
    const changed = [];
    for (let id = 0; id < this.nodes.length; id++) {
      if (this.status[id] !== beforeStatus[id] || this.feedback[id] !== beforeFeedback[id]) changed.push(id);
    }
    return changed;
  }

  apply(event) {
    for (const [id, , after, feedback] of event.changes || []) {
      this.status[id] = after;
      this.feedback[id] = feedback;
    }
    for (const [key, value] of Object.entries(event.bb || {})) this.blackboard.set(key, value);
    for (const key of event.bb_unset || []) this.blackboard.delete(key);
  }

  // The time of the last status change at or before the applied events (as `pegbt log replay` reports it).
  timeOfApplied() {
    if (this.applied) return this.events[this.applied - 1].t;
    return this.base ? this.base.t : 0;
  }

  firstFailure() {
    if (this.base && this.base.failures.length) {
      const [node, n] = this.base.failures[0];
      return { n, node };
    }
    for (const event of this.events) {
      for (const change of event.changes || []) if (change[2] === "FAILURE") return { n: event.n, node: change[0] };
    }
    return null;
  }

  failureTicks() {
    const ticks = this.base ? this.base.failures.map((failure) => failure[1]) : [];
    for (const event of this.events) {
      if ((event.changes || []).some((change) => change[2] === "FAILURE")) ticks.push(event.n);
    }
    return ticks;
  }

  isLeaf(id) {
    return !this.childCount || !this.childCount[id];
  }

  countChildren() {
    this.childCount = new Array(this.nodes.length).fill(0);
    for (const node of this.nodes) if (node.parent !== null) this.childCount[node.parent]++;
  }
}
