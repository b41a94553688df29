// thermoswarm view: the page's whole program (no libraries, nothing from the internet).
// Frames come from a Source: the local server (fetch of float32 little-endian arrays)
// or, in a self-contained file, base64 arrays embedded in the page.  A frame holds
// K*2*N positions (keypoint-major, x block then y block) and N values of the colour
// variable.  Robots are drawn as Canvas 2D circles when few, and as pixels written
// straight into an ImageData buffer when many (1,000,000 robots in a few ms).
"use strict";
(function () {
  const $ = (id) => document.getElementById(id);
  const SPLAT_ABOVE = 2000;        // more robots, each under 4 px: pixel discs, not paths
  const CACHE_BYTES = 400e6;       // frames kept in memory
  const MAX_INFLIGHT = 4;          // concurrent frame requests
  const VIRIDIS = [[68, 1, 84], [72, 40, 120], [62, 74, 137], [49, 104, 142], [38, 130, 142],
    [31, 158, 137], [53, 183, 121], [109, 205, 89], [180, 222, 44], [253, 231, 37]];
  const TAB10 = [[31, 119, 180], [255, 127, 14], [44, 160, 44], [214, 39, 40], [148, 103, 189],
    [140, 86, 75], [227, 119, 194], [127, 127, 127], [188, 189, 34], [23, 190, 207]];
  const NAN_RGB = [170, 170, 170];

  // ------------------------------------------------------------------ sources
  function b64bytes(s) {
    const bin = atob(s); const out = new Uint8Array(bin.length);
    for (let i = 0; i < bin.length; i++) out[i] = bin.charCodeAt(i);
    return out.buffer;
  }
  function served() {
    const base = location.pathname.endsWith("/") ? location.pathname : location.pathname + "/";
    const get = async (path, how) => {
      const r = await fetch(base + path, { cache: "no-store" });
      if (!r.ok) throw new Error(path + ": " + r.status + " " + (await r.text()).slice(0, 200));
      return how === "json" ? r.json() : how === "blob" ? r.blob() : r.arrayBuffer();
    };
    return {
      meta: () => get("api/meta", "json"),
      frame: async (k, v) => new Float32Array(await get("api/frame/" + k + "?var=" +
        encodeURIComponent(v || ""))),
      series: (i) => get("api/series/" + i, "json"),
      videoUrl: async (k) => URL.createObjectURL(await get("api/video/" + k, "blob")),
    };
  }
  function embedded(E) {
    const dec = (b) => new Float32Array(b64bytes(b));
    const frame = async (k, v) => {
      const pos = dec(E.pos[k]);
      const n = E.meta.n, out = new Float32Array(pos.length + n);
      out.set(pos);
      if (v && E.vars[v]) out.set(dec(E.vars[v][k]), pos.length); else out.fill(NaN, pos.length);
      return out;
    };
    return {
      meta: async () => E.meta,
      frame,
      series: async (i) => {
        const m = E.meta, out = { id: m.ids[i], time: m.time };
        for (const v of ["speed", "energy"]) {
          out[v] = [];
          for (let k = 0; k < m.n_frames; k++) out[v].push(dec(E.vars[v][k])[i]);
        }
        return out;
      },
      videoUrl: async (k) => E.video ? "data:image/jpeg;base64," + E.video[k] : null,
    };
  }
  const E = window.__EMBED__;
  const src = E ? embedded(E) : served();

  // ------------------------------------------------------------------ state
  const S = {
    meta: null, k: 0, playing: false, speed: 1, varName: "", trail: 0, sel: -1,
    zoom: 1, cx: 0, cy: 0, cache: new Map(), cacheBytes: 0, inflight: new Map(),
    video: new Map(), series: null, lastAdvance: 0, dirty: true, error: null,
    stats: { shown: [], drawMs: [], fetchMs: [] },
  };
  const canvas = $("view"), ctx = canvas.getContext("2d");
  const splatCanvas = document.createElement("canvas");
  let splatImage = null;

  function note(text, isError) {
    const d = document.createElement("div");
    d.textContent = text; if (isError) d.className = "err";
    $("notes").appendChild(d);
  }
  function fail(err) {
    const msg = String(err && err.message ? err.message : err);
    if (S.error === msg) return;
    S.error = msg; note("error: " + msg, true);
  }

  // ------------------------------------------------------------------ frames
  const key = (k, v) => k + "|" + v;
  function cached(k) { return S.cache.get(key(k, S.varName)); }
  function request(k) {
    const m = S.meta; if (!m || k < 0 || k >= m.n_frames) return;
    const kk = key(k, S.varName);
    if (S.cache.has(kk) || S.inflight.has(kk) || S.inflight.size >= MAX_INFLIGHT) return;
    const t0 = performance.now(), v = S.varName;
    const p = src.frame(k, v).then((arr) => {
      S.stats.fetchMs.push(performance.now() - t0);
      S.cache.set(key(k, v), arr); S.cacheBytes += arr.byteLength;
      while (S.cacheBytes > CACHE_BYTES && S.cache.size > 2) {
        const first = S.cache.keys().next().value;
        S.cacheBytes -= S.cache.get(first).byteLength; S.cache.delete(first);
      }
      if (k === S.k) S.dirty = true;
    }).catch(fail).finally(() => S.inflight.delete(kk));
    S.inflight.set(kk, p);
  }
  function requestVideo(k) {
    const m = S.meta; if (!m || !m.video || S.video.has(k) || k < 0 || k >= m.n_frames) return;
    const img = new Image(); S.video.set(k, img);
    src.videoUrl(k).then((url) => {
      if (!url) return;
      img.onload = () => { if (k === S.k) S.dirty = true; };
      img.onerror = () => { img.failed = true; fail("video frame " + k + " could not be shown"); };
      img.src = url;
    }).catch((e) => { S.video.delete(k); fail(e); });
    while (S.video.size > 40) {
      const first = S.video.keys().next().value;
      if (S.video.get(first).src.startsWith("blob:")) URL.revokeObjectURL(S.video.get(first).src);
      S.video.delete(first);
    }
  }
  // A video frame is ready once decoded (an Image without src also says "complete").
  function videoReady(k) {
    const img = S.video.get(k);
    return !!img && (img.failed || (img.complete && img.naturalWidth > 0));
  }
  function prefetch() {
    const ahead = S.meta.n > 300000 ? 3 : 6;
    request(S.k);
    for (let j = 1; j <= ahead; j++) request(S.k + j);
    if (S.meta.video && $("showvideo").checked) for (let j = 0; j <= ahead; j++) requestVideo(S.k + j);
    if (S.trail > 0 && S.meta.n * S.trail <= 4e6)
      for (let j = 1; j <= S.trail; j++) request(S.k - j);
  }

  // ------------------------------------------------------------------ colours
  function varInfo() { return S.meta.variables.find((v) => v.name === S.varName); }
  function colourOf(info) {
    if (!info) return () => NAN_RGB;
    if (info.kind === "categorical") {
      const idx = new Map(info.categories.map((c, i) => [c.value, TAB10[i % 10]]));
      return (x) => idx.get(x) || NAN_RGB;
    }
    const lo = info.min, span = info.max - info.min || 1;
    return (x) => {
      if (!Number.isFinite(x)) return NAN_RGB;
      let t = (x - lo) / span; t = t < 0 ? 0 : t > 1 ? 1 : t;
      const f = t * (VIRIDIS.length - 1), i = Math.min(Math.floor(f), VIRIDIS.length - 2);
      const a = VIRIDIS[i], b = VIRIDIS[i + 1], u = f - i;
      return [a[0] + (b[0] - a[0]) * u, a[1] + (b[1] - a[1]) * u, a[2] + (b[2] - a[2]) * u];
    };
  }
  // Values -> one of 64 colour bins (NaN: bin 64), so that each bin is one canvas path.
  function binner(info) {
    if (info && info.kind === "categorical") {
      const idx = new Map(info.categories.map((c, i) => [c.value, i]));
      return { bins: info.categories.map((c, i) => TAB10[i % 10]),
        of: (x) => { const i = idx.get(x); return i === undefined ? -1 : i; } };
    }
    const col = colourOf(info), bins = [];
    for (let i = 0; i < 64; i++) bins.push(col(info.min + (info.max - info.min) * (i + 0.5) / 64));
    const lo = info.min, span = info.max - info.min || 1;
    return { bins, of: (x) => {
      if (!Number.isFinite(x)) return -1;
      const i = Math.floor((x - lo) / span * 64); return i < 0 ? 0 : i > 63 ? 63 : i; } };
  }
  const css = (c) => "rgb(" + (c[0] | 0) + "," + (c[1] | 0) + "," + (c[2] | 0) + ")";
  function fmt(x, units) {
    if (x === null || x === undefined || !Number.isFinite(x)) return "-";
    const a = Math.abs(x);
    const s = a !== 0 && (a >= 1e5 || a < 1e-3) ? x.toExponential(3) : x.toPrecision(4);
    return units ? s + " " + units : s;
  }
  function legend() {
    const info = varInfo(), el = $("legend"); el.innerHTML = "";
    if (!info) return;
    const h = document.createElement("div");
    h.textContent = info.name + (info.units ? " (" + info.units + ")" : "") +
      (info.long_name ? ": " + info.long_name : "");
    el.appendChild(h);
    if (info.kind === "categorical") {
      info.categories.forEach((c, i) => {
        const r = document.createElement("div"), sw = document.createElement("span");
        sw.className = "sw"; sw.style.background = css(TAB10[i % 10]);
        r.appendChild(sw); r.appendChild(document.createTextNode(c.label)); el.appendChild(r);
      });
      return;
    }
    const bar = document.createElement("div"); bar.className = "bar";
    bar.style.background = "linear-gradient(to right," + VIRIDIS.map(css).join(",") + ")";
    const ticks = document.createElement("div"); ticks.className = "ticks";
    for (const x of [info.min, (info.min + info.max) / 2, info.max]) {
      const s = document.createElement("span"); s.textContent = fmt(x); ticks.appendChild(s);
    }
    el.appendChild(bar); el.appendChild(ticks);
    const nn = document.createElement("div"); nn.className = "muted";
    nn.textContent = "1st to 99th percentile; grey: unknown"; el.appendChild(nn);
  }

  // ------------------------------------------------------------------ geometry
  function toScreen(x, y) {
    const W = canvas.width, H = canvas.height, z = S.zoom;
    return [(x - S.cx) * z + W / 2, S.meta.y_down ? (y - S.cy) * z + H / 2 : H / 2 - (y - S.cy) * z];
  }
  function toWorld(px, py) {
    const W = canvas.width, H = canvas.height, z = S.zoom;
    return [(px - W / 2) / z + S.cx, S.meta.y_down ? (py - H / 2) / z + S.cy : (H / 2 - py) / z + S.cy];
  }
  function fit() {
    const b = S.meta.bounds, W = canvas.width, H = canvas.height;
    S.zoom = 0.95 * Math.min(W / (b[2] - b[0] || 1), H / (b[3] - b[1] || 1));
    S.cx = (b[0] + b[2]) / 2; S.cy = (b[1] + b[3]) / 2; S.dirty = true;
  }
  function shadow(cx, cy, r, light, reach) {
    if (!light) return null;
    if (light.kind === "directional") {
      let [ux, uy] = light.direction; const L = Math.hypot(ux, uy) || 1; ux /= L; uy /= L;
      const px = -uy, py = ux;
      const a = [cx + r * px, cy + r * py], b = [cx - r * px, cy - r * py];
      return [a, [a[0] + reach * ux, a[1] + reach * uy], [b[0] + reach * ux, b[1] + reach * uy], b];
    }
    const [lx, ly] = light.position, d = Math.hypot(cx - lx, cy - ly);
    if (d <= r) return null;
    const base = Math.atan2(cy - ly, cx - lx), half = Math.asin(r / d), tl = Math.sqrt(d * d - r * r);
    const pts = [];
    for (const s of [1, -1]) {
      const ang = base + s * half, ux = Math.cos(ang), uy = Math.sin(ang);
      pts.push([[lx + tl * ux, ly + tl * uy], [lx + (tl + reach) * ux, ly + (tl + reach) * uy]]);
    }
    return [pts[0][0], pts[0][1], pts[1][1], pts[1][0]];
  }
  function poly(pts, fill) {
    ctx.beginPath();
    pts.forEach((p, i) => { const [x, y] = toScreen(p[0], p[1]); i ? ctx.lineTo(x, y) : ctx.moveTo(x, y); });
    ctx.closePath(); ctx.fillStyle = fill; ctx.fill();
  }
  function circle(x, y, r, fill, stroke) {
    const [sx, sy] = toScreen(x, y);
    ctx.beginPath(); ctx.arc(sx, sy, Math.max(r * S.zoom, 1), 0, 2 * Math.PI);
    if (fill) { ctx.fillStyle = fill; ctx.fill(); }
    if (stroke) { ctx.strokeStyle = stroke; ctx.lineWidth = 1.2; ctx.stroke(); }
  }
  const m_y = (v) => (S.meta.y_down ? -v : v);
  function drawRegions() {
    ctx.strokeStyle = "rgba(120,60,160,0.8)"; ctx.lineWidth = 1.5; ctx.setLineDash([4, 3]);
    ctx.fillStyle = "rgba(120,60,160,0.9)"; ctx.font = "12px system-ui, sans-serif";
    for (const r of S.meta.regions || []) {
      ctx.beginPath();
      r.vertices.forEach((p, i) => { const [x, y] = toScreen(p[0], p[1]); i ? ctx.lineTo(x, y) : ctx.moveTo(x, y); });
      ctx.closePath(); ctx.stroke();
      const [x, y] = toScreen(r.vertices[0][0], r.vertices[0][1]);
      ctx.fillText(r.name, x + 4, y - 4);
    }
    ctx.setLineDash([]);
  }
  function drawGeometry(k) {
    drawRegions();
    const g = S.meta.geometry; if (!g) return;
    const b = g.bounds, reach = 3 * Math.hypot(b[2] - b[0], b[3] - b[1]);
    const objs = S.meta.per_frame.object_position;
    const bodies = (g.bodies || []).map((bd, i) => {
      const p = objs && objs[k] && i === 0 ? objs[k] : [bd.x, bd.y];
      return [p[0], p[1], bd.r];
    });
    ctx.save(); ctx.beginPath();  // shadows stop at the world's edge
    const [bx0, by0] = toScreen(b[0], b[1]), [bx1, by1] = toScreen(b[2], b[3]);
    ctx.rect(Math.min(bx0, bx1), Math.min(by0, by1), Math.abs(bx1 - bx0), Math.abs(by1 - by0));
    ctx.clip();
    for (const [x, y, r] of bodies.concat(g.shadow_discs || [])) {
      const s = shadow(x, y, r, g.light, reach); if (s) poly(s, "rgba(0,0,0,0.10)");
    }
    ctx.restore();
    if (g.light && g.light.kind === "directional") {  // where the light comes from
      const [ux, uy] = g.light.direction, [mx, my] = toScreen((b[0] + b[2]) / 2, (b[1] + b[3]) / 2);
      const half = Math.min(canvas.width, canvas.height) / 2 - 14, L = Math.hypot(ux, uy) || 1;
      const sx = mx - (ux / L) * half, sy = my + (m_y(uy) / L) * half;
      ctx.fillStyle = "#c98a00"; ctx.font = "12px system-ui, sans-serif"; ctx.textAlign = "center";
      ctx.fillText("light " + (uy < 0 ? "\u2193" : uy > 0 ? "\u2191" : ux > 0 ? "\u2192" : "\u2190"),
        sx, sy + 4);
      ctx.textAlign = "start";
    }
    if (g.target_y !== null && g.target_y !== undefined) {
      const [x0, y0] = toScreen(b[0], g.target_y), [x1] = toScreen(b[2], g.target_y);
      ctx.setLineDash([6, 4]); ctx.strokeStyle = "#2ca02c"; ctx.lineWidth = 1;
      ctx.beginPath(); ctx.moveTo(x0, y0); ctx.lineTo(x1, y0); ctx.stroke(); ctx.setLineDash([]);
    }
    ctx.strokeStyle = "#222"; ctx.lineWidth = 2; ctx.beginPath();
    for (const s of g.walls || []) {
      const [a, c] = toScreen(s[0], s[1]), [d, e] = toScreen(s[2], s[3]);
      ctx.moveTo(a, c); ctx.lineTo(d, e);
    }
    ctx.stroke();
    const pist = S.meta.per_frame.walls;
    (g.pistons || []).forEach((p, i) => {
      const pos = pist && pist[k] ? pist[k][i] : p.position;
      const ends = p.axis === 0 ? [[pos, p.lo], [pos, p.hi]] : [[p.lo, pos], [p.hi, pos]];
      const [a, c] = toScreen(ends[0][0], ends[0][1]), [d, e] = toScreen(ends[1][0], ends[1][1]);
      ctx.strokeStyle = "#b5179e"; ctx.lineWidth = 4;
      ctx.beginPath(); ctx.moveTo(a, c); ctx.lineTo(d, e); ctx.stroke();
    });
    for (const [x, y, r] of g.discs || []) circle(x, y, r, "#999", "#333");
    for (const [x, y, r] of bodies) circle(x, y, r, "rgba(255,255,255,0.9)", "#000");
    if (g.light && g.light.kind === "point") {
      const [x, y] = toScreen(g.light.position[0], g.light.position[1]);
      ctx.fillStyle = "#f2b705"; ctx.beginPath(); ctx.arc(x, y, 7, 0, 2 * Math.PI); ctx.fill();
    }
  }

  // ------------------------------------------------------------------ drawing
  function refIndex() {
    const kp = S.meta.keypoints;
    for (const name of ["centroid", "body", "thorax"]) if (kp.includes(name)) return kp.indexOf(name);
    return 0;
  }
  function drawRobots(arr) {
    const m = S.meta, n = m.n, K = m.keypoints.length, r0 = refIndex();
    const xs = arr.subarray(r0 * 2 * n, r0 * 2 * n + n), ys = arr.subarray(r0 * 2 * n + n, (r0 + 1) * 2 * n);
    const vals = arr.subarray(K * 2 * n, K * 2 * n + n), info = varInfo();
    const rad = m.radius ? m.radius * S.zoom : 0;
    S.stats.mode = n > SPLAT_ABOVE && rad < 4 ? "pixels" : "circles";
    if (S.stats.mode === "pixels") return splat(xs, ys, vals, info, rad);
    const bn = binner(info), paths = bn.bins.map(() => new Path2D()), nanPath = new Path2D();
    const r = Math.max(rad, m.radius ? 1.2 : 3);
    const W = canvas.width, H = canvas.height;
    for (let i = 0; i < n; i++) {
      const x = xs[i], y = ys[i]; if (!(x === x && y === y)) continue;
      const [sx, sy] = toScreen(x, y);
      if (sx < -r || sy < -r || sx > W + r || sy > H + r) continue;
      const b = bn.of(vals[i]), p = b < 0 ? nanPath : paths[b];
      p.moveTo(sx + r, sy); p.arc(sx, sy, r, 0, 2 * Math.PI);
    }
    paths.forEach((p, i) => { ctx.fillStyle = css(bn.bins[i]); ctx.fill(p); });
    ctx.fillStyle = css(NAN_RGB); ctx.fill(nanPath);
    if (K > 1) drawKeypoints(arr, n, K);
  }
  function splat(xs, ys, vals, info, rad) {
    const W = canvas.width, H = canvas.height;
    if (!splatImage || splatImage.width !== W || splatImage.height !== H) {
      splatCanvas.width = W; splatCanvas.height = H; splatImage = new ImageData(W, H);
    }
    const buf = new Uint32Array(splatImage.data.buffer); buf.fill(0);
    const bn = binner(info);
    const lut = bn.bins.map((c) => (255 << 24) | ((c[2] | 0) << 16) | ((c[1] | 0) << 8) | (c[0] | 0));
    const nanc = (255 << 24) | (NAN_RGB[2] << 16) | (NAN_RGB[1] << 8) | NAN_RGB[0];
    const z = S.zoom, ox = W / 2 - S.cx * z, yd = S.meta.y_down;
    const oy = yd ? H / 2 - S.cy * z : H / 2 + S.cy * z, sy = yd ? z : -z;
    // a disc of radius R px as offsets into the buffer (R = 0: one pixel)
    const R = Math.max(0, Math.round(rad - 0.25)), offs = [];
    for (let dy = -R; dy <= R; dy++)
      for (let dx = -R; dx <= R; dx++) if (dx * dx + dy * dy <= R * R + R) offs.push(dy * W + dx);
    const m = offs.length;
    for (let i = 0, n = xs.length; i < n; i++) {
      const px = (xs[i] * z + ox) | 0, py = (ys[i] * sy + oy) | 0;
      if (px < R || py < R || px >= W - R || py >= H - R) continue;  // NaN fails too
      const b = bn.of(vals[i]), c = b < 0 ? nanc : lut[b], o = py * W + px;
      if (m === 1) buf[o] = c; else for (let j = 0; j < m; j++) buf[o + offs[j]] = c;
    }
    splatCanvas.getContext("2d").putImageData(splatImage, 0, 0);
    ctx.drawImage(splatCanvas, 0, 0);
  }
  function drawKeypoints(arr, n, K) {
    const cols = ["#d62728", null, "#1f77b4"];
    ctx.strokeStyle = "rgba(0,0,0,0.55)"; ctx.lineWidth = 1; ctx.beginPath();
    for (let i = 0; i < n; i++) {
      let started = false;
      for (let j = 0; j < K; j++) {
        const x = arr[j * 2 * n + i], y = arr[j * 2 * n + n + i]; if (!(x === x)) continue;
        const [sx, sy] = toScreen(x, y);
        if (started) ctx.lineTo(sx, sy); else { ctx.moveTo(sx, sy); started = true; }
      }
    }
    ctx.stroke();
    [0, K - 1].forEach((j, c) => {
      ctx.fillStyle = cols[c * 2]; ctx.beginPath();
      for (let i = 0; i < n; i++) {
        const x = arr[j * 2 * n + i], y = arr[j * 2 * n + n + i]; if (!(x === x)) continue;
        const [sx, sy] = toScreen(x, y); ctx.moveTo(sx + 2.5, sy); ctx.arc(sx, sy, 2.5, 0, 6.3);
      }
      ctx.fill();
    });
  }
  function drawTrails() {
    const m = S.meta, n = m.n, r0 = refIndex();
    if (S.trail <= 0 || n * S.trail > 4e6) return;
    const frames = [];
    for (let j = S.trail; j >= 0; j--) { const a = S.cache.get(key(S.k - j, S.varName)); if (a) frames.push(a); }
    if (frames.length < 2) return;
    // a step longer than this is a jump (a robot put back at the start): no line across
    const b = m.bounds, diag = Math.hypot(b[2] - b[0], b[3] - b[1]);
    const jump2 = Math.pow(Math.max(8 * (m.radius || 0), (m.radius ? 0.03 : 0.1) * diag), 2);
    ctx.strokeStyle = "rgba(60,60,60,0.35)"; ctx.lineWidth = 1; ctx.beginPath();
    for (let i = 0; i < n; i++) {
      let px = NaN, py = NaN;
      for (const a of frames) {
        const x = a[r0 * 2 * n + i], y = a[r0 * 2 * n + n + i];
        const [sx, sy] = toScreen(x, y);
        const near = (x - px) * (x - px) + (y - py) * (y - py) <= jump2;
        if (near) ctx.lineTo(sx, sy); else if (x === x) ctx.moveTo(sx, sy);
        px = x; py = y;
      }
    }
    ctx.stroke();
  }
  function drawTrackOverlay(k, arr) {
    const m = S.meta, n = m.n, r0 = refIndex();
    if ($("showboxes").checked && m.boxes && m.boxes[k]) {
      ctx.strokeStyle = "rgba(255,200,0,0.9)"; ctx.lineWidth = 1.3;
      for (const [, x, y, w, h] of m.boxes[k]) {
        const [a, b] = toScreen(x, y), [c, d] = toScreen(x + w, y + h);
        ctx.strokeRect(a, b, c - a, d - b);
      }
    }
    if ($("showids").checked && n <= 500) {
      ctx.font = "12px system-ui, sans-serif"; ctx.fillStyle = "#fff";
      ctx.strokeStyle = "#000"; ctx.lineWidth = 3;
      for (let i = 0; i < n; i++) {
        const x = arr[r0 * 2 * n + i], y = arr[r0 * 2 * n + n + i]; if (!(x === x)) continue;
        const [sx, sy] = toScreen(x, y), label = String(m.ids[i]).replace(/^track_/, "");
        ctx.strokeText(label, sx + 6, sy - 6); ctx.fillText(label, sx + 6, sy - 6);
      }
    }
  }
  function drawSelection(arr) {
    if (S.sel < 0) return;
    const n = S.meta.n, r0 = refIndex();
    const x = arr[r0 * 2 * n + S.sel], y = arr[r0 * 2 * n + n + S.sel];
    if (!(x === x)) return;
    const [sx, sy] = toScreen(x, y), r = Math.max((S.meta.radius || 0) * S.zoom, 4) + 5;
    ctx.strokeStyle = "#e4003a"; ctx.lineWidth = 2.5;
    ctx.beginPath(); ctx.arc(sx, sy, r, 0, 2 * Math.PI); ctx.stroke();
  }
  function draw() {
    const arr = cached(S.k); if (!arr) return false;
    const t0 = performance.now(), m = S.meta;
    ctx.fillStyle = "#f7f7f5"; ctx.fillRect(0, 0, canvas.width, canvas.height);
    if (m.video && $("showvideo").checked) {
      const img = S.video.get(S.k);
      if (videoReady(S.k) && !img.failed) {
        const [x0, y0] = toScreen(0, 0);
        ctx.drawImage(img, x0, y0, m.video.width * S.zoom, m.video.height * S.zoom);
      }
    }
    drawGeometry(S.k); drawTrails(); drawRobots(arr);
    if (m.kind === "track") drawTrackOverlay(S.k, arr);
    drawSelection(arr);
    S.stats.drawMs.push(performance.now() - t0); S.stats.shown.push(performance.now());
    if (S.stats.shown.length > 5000) { S.stats.shown.splice(0, 2500); S.stats.drawMs.splice(0, 2500); }
    S.shownK = S.k; S.dirty = false;
    updatePanel(arr);
    return true;
  }

  // ------------------------------------------------------------------ panel
  function clock() {
    const m = S.meta, t = m.time[S.k];
    $("clock").textContent = "frame " + S.k + " / " + (m.n_frames - 1) + ", t = " +
      (t === null ? "-" : fmt(t, "s"));
    $("slider").value = String(S.k);
  }
  function updatePanel(arr) {
    clock();
    const el = $("selected");
    if (S.sel < 0) return;
    const m = S.meta, n = m.n, K = m.keypoints.length, r0 = refIndex(), info = varInfo();
    const rows = [["id", m.ids[S.sel] || String(S.sel)],
      ["x", fmt(arr[r0 * 2 * n + S.sel], m.units)], ["y", fmt(arr[r0 * 2 * n + n + S.sel], m.units)]];
    const ser = S.series;
    if (ser && ser.index === S.sel) {
      rows.push(["speed", fmt(ser.speed[S.k], "mm/s")], ["energy", fmt(ser.energy[S.k], "mm^2/s^2")]);
    }
    if (info && info.name !== "speed" && info.name !== "energy") {
      const v = arr[K * 2 * n + S.sel], cat = (info.categories || []).find((c) => c.value === v);
      rows.push([info.name, cat ? cat.label : fmt(v, info.units)]);
    }
    const table = document.createElement("table");  // text only: names come from files
    for (const [a, b] of rows) {
      const tr = table.insertRow(), td0 = tr.insertCell(), td1 = tr.insertCell();
      td0.textContent = a; td1.textContent = b; td1.className = "v"; td1.id = "sel-" + a;
    }
    el.replaceChildren(table);
    if (ser && ser.index === S.sel) {
      plot($("plot-speed"), ser.time, ser.speed, "speed (mm/s)");
      plot($("plot-energy"), ser.time, ser.energy, "energy (mm^2/s^2)");
    }
  }
  function plot(cv, t, y, label) {
    const W = cv.width = cv.clientWidth * devicePixelRatio, H = cv.height = cv.clientHeight * devicePixelRatio;
    const c = cv.getContext("2d"); c.clearRect(0, 0, W, H);
    let lo = Infinity, hi = -Infinity, t0 = Infinity, t1 = -Infinity;
    for (let i = 0; i < y.length; i++) {
      if (Number.isFinite(y[i])) { lo = Math.min(lo, y[i]); hi = Math.max(hi, y[i]); }
      if (Number.isFinite(t[i])) { t0 = Math.min(t0, t[i]); t1 = Math.max(t1, t[i]); }
    }
    c.font = 11 * devicePixelRatio + "px system-ui"; c.fillStyle = "#333";
    if (!(hi >= lo)) { c.fillText(label + ": no data", 6, 14 * devicePixelRatio); return; }
    if (hi === lo) hi = lo + 1; if (t1 === t0) t1 = t0 + 1;
    const X = (v) => 4 + (v - t0) / (t1 - t0) * (W - 8), Y = (v) => H - 4 - (v - lo) / (hi - lo) * (H - 22 * devicePixelRatio);
    c.strokeStyle = "#24344d"; c.lineWidth = devicePixelRatio; c.beginPath();
    let started = false;
    for (let i = 0; i < y.length; i++) {
      if (!Number.isFinite(y[i]) || !Number.isFinite(t[i])) { started = false; continue; }
      if (started) c.lineTo(X(t[i]), Y(y[i])); else { c.moveTo(X(t[i]), Y(y[i])); started = true; }
    }
    c.stroke();
    if (Number.isFinite(t[S.k])) {
      c.strokeStyle = "#e4003a"; c.beginPath(); c.moveTo(X(t[S.k]), 0); c.lineTo(X(t[S.k]), H); c.stroke();
    }
    c.fillText(label + "  " + fmt(lo) + " .. " + fmt(hi), 6, 12 * devicePixelRatio);
  }
  async function select(i) {
    S.sel = i; S.series = null; S.dirty = true;
    if (i < 0) { $("selected").textContent = "click a robot or an ant to follow it"; return; }
    try {
      const ser = await src.series(i); ser.index = i;
      if (S.sel === i) { S.series = ser; S.dirty = true; }
    } catch (e) { fail(e); }
  }
  function pick(px, py) {
    const arr = cached(S.k); if (!arr) return -1;
    const n = S.meta.n, r0 = refIndex(), [wx, wy] = toWorld(px, py);
    let best = -1, bd = Infinity;
    for (let i = 0; i < n; i++) {
      const dx = arr[r0 * 2 * n + i] - wx, dy = arr[r0 * 2 * n + n + i] - wy, d = dx * dx + dy * dy;
      if (d < bd) { bd = d; best = i; }
    }
    const tol = Math.max((S.meta.radius || 0) * 1.5, 10 / S.zoom);
    return Math.sqrt(bd) <= tol ? best : -1;
  }

  // ------------------------------------------------------------------ playback
  function setFrame(k) {
    const m = S.meta; k = Math.max(0, Math.min(m.n_frames - 1, k | 0));
    if (k !== S.k) { S.k = k; S.dirty = true; }
    clock(); prefetch();
  }
  function setPlaying(on) {
    S.playing = on; $("play").innerHTML = on ? "&#10074;&#10074; pause" : "&#9654; play";
    S.lastAdvance = performance.now();
  }
  function tick(now) {
    const m = S.meta;
    if (S.playing) {
      const next = S.k + 1;
      if (next >= m.n_frames) setPlaying(false);
      else {
        const due = S.speed === "max" ? 0 : 1000 / (m.fps * S.speed);
        const vidOk = !m.video || !$("showvideo").checked || videoReady(next);
        if (now - S.lastAdvance >= due && cached(next) && vidOk) {
          S.lastAdvance = S.speed === "max" ? now : Math.max(S.lastAdvance + due, now - due);
          S.k = next; S.dirty = true;
        }
      }
    }
    prefetch();
    if (S.dirty) draw();
    $("stats").textContent = S.stats.drawMs.length ?
      "draw " + S.stats.drawMs[S.stats.drawMs.length - 1].toFixed(1) + " ms" : "";
    requestAnimationFrame(tick);
  }
  async function refreshMeta() {
    try {
      const m = await src.meta();
      if (m.n_frames !== S.meta.n_frames) {
        S.meta = m; $("slider").max = String(m.n_frames - 1); clock();
        $("notes").innerHTML = ""; m.notes.forEach((t) => note(t));
      }
      if (!m.complete) setTimeout(refreshMeta, 3000);
    } catch (e) { fail(e); }
  }

  // ------------------------------------------------------------------ wiring
  function resize() {
    const r = canvas.getBoundingClientRect();
    canvas.width = Math.max(1, Math.round(r.width)); canvas.height = Math.max(1, Math.round(r.height));
    S.dirty = true;
  }
  function wire() {
    const m = S.meta;
    $("play").onclick = () => setPlaying(!S.playing);
    $("back").onclick = () => { setPlaying(false); setFrame(S.k - 1); };
    $("fwd").onclick = () => { setPlaying(false); setFrame(S.k + 1); };
    $("speed").onchange = (e) => { S.speed = e.target.value === "max" ? "max" : +e.target.value; };
    $("slider").max = String(m.n_frames - 1);
    $("slider").oninput = (e) => setFrame(+e.target.value);
    $("fit").onclick = fit;
    $("trail").onchange = (e) => { S.trail = Math.max(0, Math.min(500, +e.target.value | 0)); S.dirty = true; };
    const sel = $("colorby");
    for (const v of m.variables) {
      const o = document.createElement("option"); o.value = v.name;
      o.textContent = v.name + (v.units ? " (" + v.units + ")" : ""); sel.appendChild(o);
    }
    sel.value = S.varName;
    sel.onchange = (e) => { S.varName = e.target.value; legend(); S.dirty = true; prefetch(); };
    for (const id of ["showvideo", "showboxes", "showids"]) $(id).onchange = () => { S.dirty = true; };
    let drag = null;
    canvas.addEventListener("mousedown", (e) => { drag = { x: e.offsetX, y: e.offsetY, moved: false }; });
    window.addEventListener("mousemove", (e) => {
      if (!drag) return;
      const dx = e.offsetX - drag.x, dy = e.offsetY - drag.y;
      if (Math.abs(dx) + Math.abs(dy) > 3) drag.moved = true;
      if (drag.moved) {
        S.cx -= dx / S.zoom; S.cy += (m.y_down ? -dy : dy) / S.zoom;
        drag.x = e.offsetX; drag.y = e.offsetY; S.dirty = true;
      }
    });
    window.addEventListener("mouseup", (e) => {
      if (drag && !drag.moved && e.target === canvas) select(pick(e.offsetX, e.offsetY));
      drag = null;
    });
    canvas.addEventListener("wheel", (e) => {
      e.preventDefault();
      const [wx, wy] = toWorld(e.offsetX, e.offsetY), f = Math.exp(-e.deltaY * 0.0015);
      S.zoom *= f; const [nx, ny] = toWorld(e.offsetX, e.offsetY);
      S.cx += wx - nx; S.cy += wy - ny; S.dirty = true;
    }, { passive: false });
    window.addEventListener("keydown", (e) => {
      if (e.target.tagName === "INPUT" || e.target.tagName === "SELECT") return;
      if (e.key === " ") { e.preventDefault(); setPlaying(!S.playing); }
      if (e.key === "ArrowRight") setFrame(S.k + 1);
      if (e.key === "ArrowLeft") setFrame(S.k - 1);
    });
    window.addEventListener("resize", resize);
    if (m.kind === "track") {
      $("trackopts").style.display = "";
      const ev = $("events");
      if (!m.events.length) ev.textContent = "no id was lost or new";
      for (const e of m.events.slice(0, 2000)) {
        const b = document.createElement("button");
        b.textContent = "frame " + e.frame + ": " + e.kind + " " + e.id;
        b.onclick = () => { setPlaying(false); setFrame(e.frame); select(e.index); };
        ev.appendChild(b);
      }
      if (!m.video) $("showvideo").disabled = true;
    }
  }
  async function start() {
    try {
      S.meta = await src.meta();
    } catch (e) {
      $("title").textContent = "nothing to show"; fail(e); return;
    }
    const m = S.meta;
    $("title").textContent = m.title + " - " + m.n.toLocaleString() + " individuals, " +
      m.n_frames.toLocaleString() + " frames" + (m.geometry ? ", " + m.geometry.scenario : "");
    m.notes.forEach((t) => note(t));
    if (E) note("self-contained file: " + m.n_frames + " frames embedded");
    S.varName = m.default_var;
    resize(); fit(); wire(); legend(); clock(); prefetch();
    if (!m.complete) setTimeout(refreshMeta, 3000);
    requestAnimationFrame(tick);
  }
  // For tests and benchmarks: the state, and the functions the controls call.
  window.viewer = { S, setFrame, setPlaying, select, toScreen, pick, fit, videoReady,
    ready: () => !!(S.meta && S.shownK === S.k) };
  window.addEventListener("error", (e) => fail(e.message));
  start();
})();
