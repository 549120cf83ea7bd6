/*
 * Lunar-lander flight replays.
 *
 * Animates every widget that replay.rs's replay_widget() writes: a
 * <figure class="lander-replay"> holding a <canvas>, its controls (found by
 * data-role) and the flight as JSON in <script type="application/json"
 * class="lander-replay-data">. A page may hold any number of widgets and
 * inlines this script once, anywhere: it waits for the document to load.
 *
 * The world is SPEC §1's: y grows upward, x wraps at the world's edges, and
 * a hull point (px, py) sits at (x + s(px cos r + py sin r),
 * y + s(-px sin r + py cos r)). Canvas y grows downward, so y is flipped.
 *
 * Plain ES2017, no libraries, no network.
 */
(function () {
  'use strict';

  // SPEC §1: 60 ticks make a simulated second; 1× plays in real time.
  const TICKS_PER_SECOND = 60;
  // A hidden tab stops requestAnimationFrame; on return, do not jump ahead
  // by the whole time away.
  const MAX_STEP_SECONDS = 0.25;

  const COLOURS = {
    skyTop: '#03050c',
    skyHorizon: '#1d2a4a',
    star: 'rgba(255, 255, 255, 0.7)',
    ground: '#5d5f68',
    groundLine: '#9a9ca6',
    pad: '#f2c14e',
    padEdge: '#fff3c4',
    trail: 'rgba(159, 195, 255, 0.6)',
    trailThrust: '#ff9d3a',
    hullStroke: '#f4f7fc',
    body: '#b9c3d3',
    cabin: '#3d5a8a',
    nozzle: '#8a93a3',
    flameOuter: '#ff6a00',
    flameInner: '#ffe08a',
    safe: '#5bff8a',
    crash: '#ff6b6b',
  };

  // The hull's drawing parts as [name, first, end, closed]. SPEC §1 lists
  // its 30 points part by part; any other hull is one closed outline. This
  // mirrors hull_parts() in replay.rs, so the SVG and the replay agree.
  function hullParts(count) {
    if (count === 30) {
      return [
        ['body', 0, 4, true],
        ['cabin', 4, 12, false],
        ['leg', 12, 19, false],
        ['leg', 19, 26, false],
        ['nozzle', 26, 30, false],
      ];
    }
    return count > 0 ? [['outline', 0, count, true]] : [];
  }

  // The flame's base in model units: the nozzle's bottom corners, or a
  // narrow base under the lowest point of another hull.
  function flameBase(hull) {
    if (hull.length === 30) return [hull[27], hull[28]];
    let low = Infinity;
    for (const p of hull) low = Math.min(low, p[1]);
    return isFinite(low) ? [[-0.25, low], [0.25, low]] : null;
  }

  // A small deterministic generator, so the stars stay put between redraws
  // and page loads.
  function lcg(seed) {
    let state = seed >>> 0;
    return function () {
      state = (Math.imul(state, 1664525) + 1013904223) >>> 0;
      return state / 4294967296;
    };
  }

  function makeLayer(canvas) {
    const layer = document.createElement('canvas');
    layer.width = canvas.width;
    layer.height = canvas.height;
    return layer;
  }

  class Replay {
    constructor(root, flight) {
      this.root = root;
      this.flight = flight;
      this.scene = flight.scene;
      this.frames = flight.frames || [];
      this.parts = hullParts(this.scene.hull.length);
      this.flame = flameBase(this.scene.hull);

      this.canvas = root.querySelector('canvas');
      // The canvas's width and height attributes are its size in CSS pixels.
      // On a high-density screen, back it with more device pixels so lines
      // stay sharp; `px` is device pixels per CSS pixel, capped because a
      // larger canvas costs more to redraw and looks no better.
      this.px = Math.min(Math.max(window.devicePixelRatio || 1, 1), 2);
      const cssWidth = this.canvas.width;
      this.canvas.style.width = '100%';
      this.canvas.style.maxWidth = cssWidth + 'px';
      this.canvas.style.height = 'auto';
      this.canvas.width = Math.round(cssWidth * this.px);
      this.canvas.height = Math.round(this.canvas.height * this.px);
      this.ctx = this.canvas.getContext('2d');
      // Device pixels per world unit; the canvas keeps the world's aspect.
      this.k = this.canvas.width / this.scene.width;

      this.playButton = root.querySelector('[data-role="play"]');
      this.restartButton = root.querySelector('[data-role="restart"]');
      this.speedSelect = root.querySelector('[data-role="speed"]');
      this.seekBar = root.querySelector('[data-role="seek"]');
      this.status = root.querySelector('[data-role="status"]');
      this.outcome = root.querySelector('[data-role="outcome"]');

      // The scene never changes, and the trail only grows while playing, so
      // both are drawn once into layers and copied each frame; a long
      // flight then costs no more per frame than a short one.
      this.background = makeLayer(this.canvas);
      this.drawBackground(this.background.getContext('2d'));
      this.trail = makeLayer(this.canvas);
      this.trailCtx = this.trail.getContext('2d');
      this.trailEnd = 0; // the last frame the trail layer reaches

      this.pos = 0; // the tick shown, fractional while playing
      this.speed = Number(this.speedSelect ? this.speedSelect.value : 1) || 1;
      this.playing = false;
      this.lastTime = null;
      this.rafId = 0;
      this.onFrame = (time) => this.step(time);

      this.bindControls();
      this.render();
    }

    get lastIndex() {
      return Math.max(0, this.frames.length - 1);
    }

    bindControls() {
      if (this.playButton) {
        this.playButton.addEventListener('click', () => {
          if (this.playing) this.pause();
          else if (this.pos >= this.lastIndex) this.restart();
          else this.play();
        });
      }
      if (this.restartButton) {
        this.restartButton.addEventListener('click', () => this.restart());
      }
      if (this.speedSelect) {
        this.speedSelect.addEventListener('change', () => {
          this.speed = Number(this.speedSelect.value) || 1;
        });
      }
      if (this.seekBar) {
        this.seekBar.addEventListener('input', () => {
          this.seek(Number(this.seekBar.value));
        });
      }
    }

    play() {
      if (this.frames.length < 2) return;
      this.playing = true;
      this.lastTime = null;
      if (!this.rafId) this.rafId = requestAnimationFrame(this.onFrame);
      this.updateControls();
    }

    pause() {
      this.playing = false;
      if (this.rafId) cancelAnimationFrame(this.rafId);
      this.rafId = 0;
      this.updateControls();
    }

    restart() {
      this.seek(0);
      this.play();
    }

    seek(index) {
      const target = Math.max(0, Math.min(this.lastIndex, Math.floor(index)));
      if (target < this.trailEnd) {
        // The trail layer only grows; going back means drawing it anew.
        this.trailCtx.clearRect(0, 0, this.trail.width, this.trail.height);
        this.trailEnd = 0;
      }
      this.pos = target;
      this.lastTime = null;
      this.render();
    }

    step(time) {
      this.rafId = 0;
      if (!this.playing) return;
      if (this.lastTime !== null) {
        const seconds = Math.min((time - this.lastTime) / 1000, MAX_STEP_SECONDS);
        this.pos = Math.min(this.lastIndex, this.pos + seconds * TICKS_PER_SECOND * this.speed);
      }
      this.lastTime = time;
      if (this.pos >= this.lastIndex) this.playing = false;
      this.render();
      if (this.playing) this.rafId = requestAnimationFrame(this.onFrame);
    }

    // World to canvas.
    cx(x) {
      return x * this.k;
    }

    cy(y) {
      return (this.scene.height - y) * this.k;
    }

    drawBackground(ctx) {
      const scene = this.scene;
      const w = ctx.canvas.width;
      const h = ctx.canvas.height;
      const groundTop = this.cy(scene.ground_y);

      const sky = ctx.createLinearGradient(0, 0, 0, groundTop);
      sky.addColorStop(0, COLOURS.skyTop);
      sky.addColorStop(1, COLOURS.skyHorizon);
      ctx.fillStyle = sky;
      ctx.fillRect(0, 0, w, groundTop);

      const random = lcg(20020101);
      ctx.fillStyle = COLOURS.star;
      for (let i = 0; i < 90; i++) {
        const size = (random() < 0.15 ? 2 : 1) * this.px;
        ctx.fillRect(Math.floor(random() * w), Math.floor(random() * (groundTop - 4)), size, size);
      }

      ctx.fillStyle = COLOURS.ground;
      ctx.fillRect(0, groundTop, w, h - groundTop);
      ctx.strokeStyle = COLOURS.groundLine;
      ctx.lineWidth = 1.5 * this.px;
      ctx.beginPath();
      ctx.moveTo(0, groundTop);
      ctx.lineTo(w, groundTop);
      ctx.stroke();

      // The pad: a platform on the ground line, a beacon at each end.
      const left = this.cx(scene.pad_x - scene.pad_half_width);
      const right = this.cx(scene.pad_x + scene.pad_half_width);
      const thickness = 4 * this.k;
      ctx.fillStyle = COLOURS.pad;
      ctx.fillRect(left, groundTop, right - left, thickness);
      ctx.strokeStyle = COLOURS.padEdge;
      ctx.lineWidth = this.px;
      ctx.strokeRect(left, groundTop, right - left, thickness);
      const beacon = 1.3 * this.k;
      for (const [x, colour] of [[left, '#ff5b5b'], [right, '#5bff8a']]) {
        ctx.fillStyle = colour;
        ctx.beginPath();
        ctx.arc(x, groundTop - beacon - this.px, beacon, 0, 2 * Math.PI);
        ctx.fill();
      }
    }

    // Extends the trail layer to frame `end`. A segment takes its frame's
    // colour (orange where the engine fired) and is left out where x wrapped
    // round the world, so no line crosses the whole screen.
    extendTrail(end) {
      const ctx = this.trailCtx;
      const frames = this.frames;
      const half = this.scene.width / 2;
      ctx.lineWidth = 1.5 * this.px;
      ctx.lineCap = 'round';
      ctx.lineJoin = 'round';
      let colour = null;
      for (let i = this.trailEnd + 1; i <= end; i++) {
        const a = frames[i - 1];
        const b = frames[i];
        if (Math.abs(b.x - a.x) > half) continue;
        const want = b.thrust ? COLOURS.trailThrust : COLOURS.trail;
        if (want !== colour) {
          if (colour !== null) ctx.stroke();
          colour = want;
          ctx.strokeStyle = colour;
          ctx.beginPath();
        }
        ctx.moveTo(this.cx(a.x), this.cy(a.y));
        ctx.lineTo(this.cx(b.x), this.cy(b.y));
      }
      if (colour !== null) ctx.stroke();
      this.trailEnd = Math.max(this.trailEnd, end);
    }

    // The lander at `frame`, moved to `x`, drawn in model units through a
    // transform that rotates, scales by hull_scale and flips y. `flame` is
    // null for no flame, else a random number in [0, 1) for its length.
    drawLander(ctx, frame, x, flame) {
      const ks = this.k * this.scene.hull_scale;
      const sin = Math.sin(frame.rot);
      const cos = Math.cos(frame.rot);
      ctx.save();
      ctx.setTransform(ks * cos, ks * sin, ks * sin, -ks * cos, this.cx(x), this.cy(frame.y));
      ctx.lineJoin = 'round';
      ctx.lineCap = 'round';

      if (flame !== null && this.flame) {
        const [a, b] = this.flame;
        const mid = (a[0] + b[0]) / 2;
        const base = Math.min(a[1], b[1]);
        const length = 0.9 + 0.7 * flame;
        ctx.fillStyle = COLOURS.flameOuter;
        ctx.beginPath();
        ctx.moveTo(a[0], a[1]);
        ctx.lineTo(mid, base - length);
        ctx.lineTo(b[0], b[1]);
        ctx.closePath();
        ctx.fill();
        ctx.fillStyle = COLOURS.flameInner;
        ctx.beginPath();
        ctx.moveTo(a[0] * 0.5 + mid * 0.5, a[1]);
        ctx.lineTo(mid, base - length * 0.55);
        ctx.lineTo(b[0] * 0.5 + mid * 0.5, b[1]);
        ctx.closePath();
        ctx.fill();
      }

      const hull = this.scene.hull;
      ctx.strokeStyle = COLOURS.hullStroke;
      // The line width is in model units here; this makes it 1.5 CSS pixels.
      ctx.lineWidth = (1.5 * this.px) / ks;
      for (const [name, first, end, closed] of this.parts) {
        ctx.beginPath();
        ctx.moveTo(hull[first][0], hull[first][1]);
        for (let i = first + 1; i < end; i++) ctx.lineTo(hull[i][0], hull[i][1]);
        if (closed) ctx.closePath();
        const fill = { body: COLOURS.body, outline: COLOURS.body, cabin: COLOURS.cabin, nozzle: COLOURS.nozzle }[name];
        if (fill) {
          ctx.fillStyle = fill;
          ctx.fill();
        }
        ctx.stroke();
      }
      ctx.restore();
    }

    render() {
      const ctx = this.ctx;
      const w = this.canvas.width;
      ctx.setTransform(1, 0, 0, 1, 0, 0);
      ctx.drawImage(this.background, 0, 0);
      if (this.frames.length === 0) {
        this.setStatus('no frames to replay');
        return;
      }

      const index = Math.floor(this.pos);
      if (index > this.trailEnd) this.extendTrail(index);
      ctx.drawImage(this.trail, 0, 0);

      const frame = this.frames[index];
      const done = index >= this.lastIndex && this.frames.length > 1;
      // The flame flickers by drawing a new length each frame; once down,
      // the engine is off and a flame would only poke into the ground.
      const flame = frame.thrust && !done ? Math.random() : null;
      // Near an edge the lander straddles the wrap: draw it on both sides.
      const reach = 2 * this.scene.hull_scale;
      this.drawLander(ctx, frame, frame.x, flame);
      if (frame.x < reach) this.drawLander(ctx, frame, frame.x + this.scene.width, flame);
      if (frame.x > this.scene.width - reach) this.drawLander(ctx, frame, frame.x - this.scene.width, flame);

      // Above the top of the world there is no ceiling: point up at it.
      if (frame.y > this.scene.height) {
        const x = this.cx(frame.x);
        const u = this.px;
        const nearRight = x > w - 80 * u;
        ctx.fillStyle = COLOURS.hullStroke;
        ctx.beginPath();
        ctx.moveTo(x, 4 * u);
        ctx.lineTo(x - 7 * u, 16 * u);
        ctx.lineTo(x + 7 * u, 16 * u);
        ctx.closePath();
        ctx.fill();
        ctx.font = 13 * u + 'px system-ui, sans-serif';
        ctx.textAlign = nearRight ? 'right' : 'left';
        ctx.fillText('y ' + Math.round(frame.y), x + (nearRight ? -10 : 10) * u, 16 * u);
      }

      if (done) this.drawOutcome(ctx);
      this.setStatus(
        'tick ' + index + ' / ' + this.lastIndex +
        '  x ' + frame.x.toFixed(1) + '  y ' + frame.y.toFixed(1) +
        '  rot ' + (frame.rot * 180 / Math.PI).toFixed(0) + '°'
      );
      if (this.outcome) {
        this.outcome.textContent = done ? (this.flight.safe ? 'safe landing' : 'crashed') : '';
        this.outcome.className = 'lander-replay-outcome' + (done ? (this.flight.safe ? ' safe' : ' crashed') : '');
      }
      if (this.seekBar && Number(this.seekBar.value) !== index) this.seekBar.value = String(index);
      this.updateControls();
    }

    drawOutcome(ctx) {
      const text = this.flight.safe ? 'SAFE LANDING' : 'CRASHED';
      ctx.font = 'bold ' + 30 * this.px + 'px system-ui, sans-serif';
      ctx.textAlign = 'center';
      ctx.textBaseline = 'middle';
      ctx.lineWidth = 4 * this.px;
      ctx.strokeStyle = 'rgba(0, 0, 0, 0.6)';
      ctx.strokeText(text, this.canvas.width / 2, this.canvas.height * 0.2);
      ctx.fillStyle = this.flight.safe ? COLOURS.safe : COLOURS.crash;
      ctx.fillText(text, this.canvas.width / 2, this.canvas.height * 0.2);
      ctx.textBaseline = 'alphabetic';
    }

    setStatus(text) {
      if (this.status) this.status.textContent = text;
    }

    updateControls() {
      if (!this.playButton) return;
      const label = this.playing ? 'Pause' : (this.pos >= this.lastIndex ? 'Replay' : 'Play');
      if (this.playButton.textContent !== label) this.playButton.textContent = label;
    }
  }

  function initWidget(root) {
    // Each widget starts once, even if this script is inlined twice.
    if (root.dataset.replayStarted) return;
    root.dataset.replayStarted = 'true';
    const data = root.querySelector('script.lander-replay-data');
    const status = root.querySelector('[data-role="status"]');
    let flight;
    try {
      flight = JSON.parse(data ? data.textContent : 'null');
    } catch (error) {
      flight = null;
    }
    if (!flight || !flight.scene || !Array.isArray(flight.frames) || !(flight.scene.width > 0)) {
      // Say so in the widget rather than break the rest of the page.
      if (status) status.textContent = 'no flight data to replay';
      return;
    }
    new Replay(root, flight).play();
  }

  function initAll() {
    document.querySelectorAll('.lander-replay').forEach(initWidget);
  }

  if (document.readyState === 'loading') {
    document.addEventListener('DOMContentLoaded', initAll);
  } else {
    initAll();
  }
})();
