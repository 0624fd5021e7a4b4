// The replay's controls: play (at a chosen multiple of the run's clock), step a tick, jump to a tick or a
// time, a range to scrub, and a strip with the failures (red), the first cause (tall red) and where we are.

export class Timeline {
  constructor(state, { seek }) {
    this.state = state;
    this.onSeek = seek;
    this.tick = 0;
    this.causes = null;
    this.playing = false;
    this.strip = document.getElementById("strip");
    this.scrub = document.getElementById("scrub");
    this.tickInput = document.getElementById("tick-input");
    this.timeInput = document.getElementById("time-input");
    document.getElementById("play").onclick = () => this.togglePlay();
    document.getElementById("step-back").onclick = () => this.seek(this.tick - 1);
    document.getElementById("step-forward").onclick = () => this.seek(this.tick + 1);
    this.tickInput.addEventListener("change", () => this.seek(Number(this.tickInput.value)));
    this.timeInput.addEventListener("change", () => this.seek(this.state.tickAtTime(Number(this.timeInput.value))));
    this.scrub.addEventListener("input", () => this.seek(Number(this.scrub.value)));
    this.strip.addEventListener("click", (event) => {
      const box = this.strip.getBoundingClientRect();
      this.seek(Math.round(((event.clientX - box.left) / box.width) * this.state.lastTick));
    });
  }

  setCauses(causes) {
    this.causes = causes;
    this.draw();
  }

  seek(tick) {
    this.onSeek(Math.max(0, Math.min(Math.round(tick), this.state.lastTick)));
  }

  show(tick) {
    this.tick = tick;
    this.scrub.max = this.state.lastTick;
    this.scrub.value = tick;
    if (document.activeElement !== this.tickInput) this.tickInput.value = tick;
    this.draw();
  }

  draw() {
    const canvas = this.strip;
    const width = (canvas.width = canvas.clientWidth || 300);
    const height = canvas.height;
    const context = canvas.getContext("2d");
    context.clearRect(0, 0, width, height);
    const last = Math.max(1, this.state.lastTick);
    const x = (tick) => (tick / last) * (width - 2) + 1;
    context.fillStyle = "#d63b2f";
    for (const tick of this.failureTicks()) context.fillRect(x(tick), height * 0.45, 1, height * 0.55);
    if (this.causes && this.causes.first) {
      context.fillRect(x(this.causes.first.n) - 2, 0, 4, height);
    }
    context.fillStyle = "#1d5fbf";
    context.fillRect(x(this.tick) - 1, 0, 2, height);
  }

  failureTicks() {
    if (this.cachedFor !== this.state.events.length) {
      this.cachedFor = this.state.events.length;
      this.cachedFailures = this.state.failureTicks();
    }
    return this.cachedFailures;
  }

  togglePlay() {
    this.playing = !this.playing;
    document.getElementById("play").textContent = this.playing ? "⏸" : "▶";
    if (!this.playing) return;
    if (this.tick >= this.state.lastTick) this.seek(0);
    const speed = () => Number(document.getElementById("speed").value);
    const startWall = performance.now();
    const startTime = this.state.timeOfApplied();
    const step = () => {
      if (!this.playing) return;
      const time = startTime + ((performance.now() - startWall) / 1000) * speed();
      const tick = this.tickBefore(time);
      if (tick > this.tick) this.seek(tick);
      if (this.tick >= this.state.lastTick) { this.togglePlay(); return; }
      requestAnimationFrame(step);
    };
    requestAnimationFrame(step);
  }

  // The last tick whose record is at or before run time `time` (records are in time order).
  tickBefore(time) {
    const events = this.state.events;
    let low = 0, high = events.length;
    while (low < high) {
      const mid = (low + high) >> 1;
      if (events[mid].t <= time) low = mid + 1; else high = mid;
    }
    return low ? events[low - 1].n : 0;
  }
}
