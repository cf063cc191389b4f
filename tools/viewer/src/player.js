// Shared playback clock for one or two synchronized views. Pure module (the animation loop
// passes the elapsed wall time in), unit-tested.

export class Player {
  constructor() {
    this.time = 0;        // seconds of rollout time
    this.duration = 0;    // seconds (longest loaded rollout)
    this.playing = false;
    this.speed = 1;
    this.loop = true;
  }

  /** Advances the clock by dt seconds of wall time (scaled by speed); wraps or stops at the end. */
  tick(dt) {
    if (!this.playing || this.duration <= 0) return;
    this.time += dt * this.speed;
    if (this.time > this.duration) {
      if (this.loop) this.time = this.time % (this.duration + 1e-9);
      else {
        this.time = this.duration;
        this.playing = false;
      }
    }
  }

  seek(t) {
    this.time = Math.min(Math.max(t, 0), this.duration);
  }
}
