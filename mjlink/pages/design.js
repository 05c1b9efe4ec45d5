// mjlink drag-to-design: the reference's closed-form position analysis, ported, and the page
// that edits a mechanism with it. Units as in mechanism files: mm, deg. One block per type,
// each the same formula as mjlink.model.blocks (Crank, Dyad, Attached, Slider), so that the
// page draws what `simulate` computes (tests/test_design_page.py compares them).
"use strict";
(function () {
  const D = Math.PI / 180;

  // ------------------------------------------------------------------ the kinematics port
  // Each block from the points before it; `L` the model's limits (`check`'s dead-point limits:
  // a dyad's least transmission angle, a slider's largest pressure angle, deg).
  const BLOCKS = {
    crank(s, P, phi, phi0) {
      const a = (phi - phi0) * s.ratio + (s.phase === null ? phi0 : s.phase * D);
      const p = P[s.pivot];
      return { at: [p[0] + s.length * Math.cos(a), p[1] + s.length * Math.sin(a), p[2]] };
    },
    dyad(s, P, phi, phi0, L) {
      const a = P[s.a], b = P[s.b];
      const dx = a[0] - b[0], dy = a[1] - b[1];
      const dist = Math.sqrt(dx * dx + dy * dy);
      const cu = (dist * dist + (s.length_b * s.length_b - s.length_a * s.length_a)) / (dist * (2 * s.length_b));
      const w = Math.min(1, Math.max(-1, cu));
      const sn = s.sign * Math.sqrt(1 - w * w);
      const ux = dx * (s.length_b / dist), uy = dy * (s.length_b / dist);
      const cm = (s.length_a * s.length_a + s.length_b * s.length_b - dist * dist) / (2 * s.length_a * s.length_b);
      const mu = Math.acos(Math.min(1, Math.max(-1, cm))) / D;
      return {
        at: [b[0] + (ux * w - uy * sn), b[1] + (ux * sn + uy * w), b[2]],
        closes: Math.abs(cu) <= 1,
        angle: { what: "transmission angle", value: Math.min(mu, 180 - mu), bad: Math.min(mu, 180 - mu) < L.transmission_min },
      };
    },
    attached(s, P) {
      const o = P[s.origin], t = P[s.toward];
      const dx = t[0] - o[0], dy = t[1] - o[1];
      const n = Math.sqrt(dx * dx + dy * dy);
      const ux = dx / n, uy = dy / n;
      const c = s.length * Math.cos(s.angle * D), sn = s.length * Math.sin(s.angle * D);
      return { at: [o[0] + (ux * c - uy * sn), o[1] + (ux * sn + uy * c), s.z === null ? o[2] : s.z] };
    },
    slider(s, P, phi, phi0, L) {
      const st = P[s.start], n1 = P[s.guide[0]], n2 = P[s.guide[1]];
      const gx = n2[0] - n1[0], gy = n2[1] - n1[1];
      const gn = Math.sqrt(gx * gx + gy * gy);
      const ux = gx / gn, uy = gy / gn;
      const along = (st[0] - n1[0]) * ux + (st[1] - n1[1]) * uy;
      const fx = n1[0] + ux * along, fy = n1[1] + uy * along;
      const ox = st[0] - fx, oy = st[1] - fy;
      const h2 = -(ox * ox + oy * oy) + s.length * s.length;
      const h = Math.sqrt(Math.max(h2, 0));
      const sg = s.toward === s.guide[1] ? h : -h;
      const pressure = Math.asin(Math.min(1, Math.max(0, Math.sqrt(ox * ox + oy * oy) / s.length))) / D;
      return {
        at: [fx + ux * sg, fy + uy * sg, n1[2]],
        closes: h2 >= 0,
        angle: { what: "pressure angle", value: pressure, bad: pressure > L.pressure_max },
      };
    },
  };

  function label(s) {
    if (s.kind === "dyad") return `dyad ${s.a}-${s.point}-${s.b}`;
    if (s.kind === "slider") return `slider ${s.start}-${s.point} on ${s.guide[0]}-${s.guide[1]}`;
    return `${s.kind} ${s.point}`;
  }

  // `m`'s blocks on numbered points: every point name of a block replaced by the point's place
  // in `names` (the ground's, then the blocks' in order), so that the loops over many input
  // angles read arrays, and every block function sees one kind of argument.
  function numbered(m) {
    const names = [...Object.keys(m.ground), ...m.steps.map((s) => s.point)];
    const index = (name) => names.indexOf(name);
    const steps = m.steps.map((s) => {
      const c = { ...s };
      for (const f of ["pivot", "a", "b", "origin", "toward", "start", "point"]) if (typeof s[f] === "string") c[f] = index(s[f]);
      if (s.guide) c.guide = s.guide.map(index);
      return c;
    });
    return { names, index, steps, labels: m.steps.map(label), ground: Object.keys(m.ground).map((k) => m.ground[k]) };
  }

  // Every point at input crank angle phiDeg (deg), mm, by number (`c` = numbered(m)); `open`:
  // the blocks that cannot close there, `dead`: those past their dead-point limit, `angles`:
  // each such block's angle.
  function solveAt(c, m, phiDeg) {
    const P = c.ground.slice();
    const open = [], dead = [], angles = [];
    for (let j = 0; j < c.steps.length; j++) {
      const s = c.steps[j];
      const r = BLOCKS[s.kind](s, P, phiDeg * D, m.phi0 * D, m.limits);
      P[s.point] = r.at;
      if (r.closes === false) open.push(c.labels[j]);
      if (r.angle) {
        angles.push({ block: c.labels[j], what: r.angle.what, value: r.angle.value });
        if (r.angle.bad && r.closes !== false) dead.push(c.labels[j]);
      }
    }
    return { P, open, dead, angles };
  }

  // solveAt with the points by name.
  function solve(m, phiDeg) {
    const c = numbered(m);
    const r = solveAt(c, m, phiDeg);
    return { ...r, P: Object.fromEntries(c.names.map((n, i) => [n, r.P[i]])) };
  }

  // ---------------------------------------------------------------- the design's numbers
  function samples(m, perTurn, c) {
    const n = perTurn * m.turns;
    const out = [];
    for (let k = 0; k < n; k++) {
      const phi = m.phi0 + (360 * m.turns * k) / n;
      out.push({ phi, ...solveAt(c, m, phi) });
    }
    return out;
  }

  // An input angle (deg) within one period (`span`, deg) from 0.
  function within(phi, span) {
    const v = ((phi % span) + span) % span;
    return Math.abs(v - span) < 1e-9 ? 0 : v;
  }

  // The input-angle ranges (deg) where `flags` holds, from the first sample to the last of each,
  // as `check` writes them (mjlink.reference.angle_ranges): within one period (`span`) from 0, in
  // order, a range running through the samples' start one range and one running through 0 its
  // two parts ("0.0..10.0, 350.0..360.0"; `phis` cover the whole period, both ends included).
  function ranges(phis, flags, span) {
    const spans = [];
    let start = -1;
    for (let i = 0; i < flags.length; i++) {
      if (flags[i] && start < 0) start = i;
      if ((!flags[i] || i === flags.length - 1) && start >= 0) {
        spans.push([start, flags[i] ? i : i - 1]);
        start = -1;
      }
    }
    if (spans.length > 1 && spans[0][0] === 0 && spans[spans.length - 1][1] === flags.length - 1) spans[0][0] = spans.pop()[0];
    const parts = [];
    for (const [a, b] of spans) {
      const lo = within(phis[a], span), hi = within(phis[b], span);
      if (lo <= hi || a === b) parts.push([lo, hi]);
      else parts.push([0, hi], [lo, span]);
    }
    parts.sort((u, v) => u[0] - v[0] || u[1] - v[1]);
    const out = parts.map(([lo, hi]) => `${lo.toFixed(1)}..${hi.toFixed(1)}`);
    return out.slice(0, 6).join(", ") + (out.length > 6 ? " ..." : "");
  }

  // The extreme (sense 1: highest, -1: lowest) of a periodic sampled curve, refined by the
  // parabola through the extreme sample and its neighbours (the samples alone are off by up to
  // a quarter of the curvature times the step squared).
  function peak(y, sense) {
    const n = y.length;
    let i = 0;
    for (let k = 1; k < n; k++) if (sense * y[k] > sense * y[i]) i = k;
    const a = y[(i - 1 + n) % n], b = y[i], c = y[(i + 1) % n];
    const curv = a - 2 * b + c;
    return curv === 0 ? b : b - ((a - c) * (a - c)) / (8 * curv);
  }

  function threadLength(thread, P) {
    let l = 0;
    for (let i = 1; i < thread.length; i++) {
      const a = P[thread[i - 1]], b = P[thread[i]];
      l += Math.hypot(b[0] - a[0], b[1] - a[1], b[2] - a[2]);
    }
    return l;
  }

  // The metrics a study names the same way (mjlink.analysis.metrics), from `perTurn` samples
  // per input turn; `closes` false (metrics empty) where a block does not close at a sample.
  // Whether the design is feasible is `problems`' to say. The samples' points are by number.
  function metrics(m, perTurn) {
    const c = numbered(m);
    const S = samples(m, perTurn, c);
    const lf = m.thread ? S.map((s) => threadLength(m.thread.map(c.index), s.P)) : null;
    const out = { samples: S, closes: !S.some((s) => s.open.length), values: {}, thread: lf };
    if (!out.closes) return out;
    const key = m.key, k = c.index(key);
    const xs = [0, 1, 2].map((ax) => S.map((s) => s.P[k][ax]));
    const spans = xs.map((v) => Math.max(...v) - Math.min(...v));
    const ax = spans.indexOf(Math.max(...spans));
    const v = out.values;
    const lo = peak(xs[ax], -1), hi = peak(xs[ax], 1);
    v[`stroke_${key}`] = hi - lo;
    v[`${key}_${"xyz"[ax]}_min`] = lo;
    v[`${key}_${"xyz"[ax]}_max`] = hi;
    if (lf) {
      let rise = 0;
      for (let i = 0; i < lf.length; i++) rise += Math.max(0, lf[(i + 1) % lf.length] - lf[i]);
      v.thread_feed = rise / m.turns;
    }
    const tr = S.flatMap((s) => s.angles.filter((a) => a.what === "transmission angle").map((a) => a.value));
    if (tr.length) v.transmission_min = Math.min(...tr);
    const pr = S.flatMap((s) => s.angles.filter((a) => a.what === "pressure angle").map((a) => a.value));
    if (pr.length) v.pressure_max = Math.max(...pr);
    return out;
  }

  // ---------------------------------------------------------------- what `check` refuses
  function get(m, path) {
    const [section, name, key] = path.split(".");
    if (section === "ground") return m.ground[name]["xyz".indexOf(key)];
    if (section === "construct") return m.steps.find((s) => s.point === name)[key];
    return path === "input.phi0" ? m.phi0 : undefined;
  }

  // Points of a block that must never meet (the direction they define), as its `directions`.
  function directions(s) {
    if (s.kind === "dyad") return [[s.a, s.b, "a and b"]];
    if (s.kind === "attached") return [[s.origin, s.toward, "origin and toward"]];
    if (s.kind === "slider") return [[s.guide[0], s.guide[1], "guide points"]];
    return [];
  }

  // The numbers of `m` the file's reader refuses, one line each (mjlink.model.reader: > 0,
  // >= 0, the least and the largest magnitude; `limits.values` holds each number's rule).
  function refused(m) {
    const out = [];
    for (const path in m.limits.values) {
      const r = m.limits.values[path], v = get(m, path);
      if (v === null || v === undefined) continue;
      const got = `got ${v}${r.unit ? " " + r.unit : ""}`;
      const bound = (b) => `${b}${r.unit ? " " + r.unit : ""}`;
      if (!Number.isFinite(v)) out.push(`${path} must be finite, ${got}`);
      else if (r.positive && v <= 0) out.push(`${path} must be > 0, ${got}`);
      else if (r.nonneg && v < 0) out.push(`${path} must be >= 0, ${got}`);
      else if (r.hi !== undefined && Math.abs(v) > r.hi) out.push(`${path} must be at most ${bound(r.hi)} in magnitude, ${got}`);
      else if (r.lo !== undefined && Math.abs(v) < r.lo) out.push(`${path} must be at least ${bound(r.lo)} in magnitude, ${got}`);
    }
    return out;
  }

  // What `check` refuses in the design `m`, in its order and words (mjlink.validation), one line
  // each ([] where it passes): a number the file's reader refuses (check reads no further);
  // then, at check's own input angles (`per_turn` a turn over the period, both ends included),
  // a block that cannot close (nothing further), two points that define a direction or a guide
  // meeting, or a point left undefined (nothing further); a link that is not rigid; two points
  // of one link almost coinciding at phi0; a block past its dead-point limit.
  function problems(m) {
    const L = m.limits;
    const out = refused(m);
    if (out.length) return out;

    const n = L.per_turn * m.turns + 1, span = 360 * m.turns;
    const steps = m.steps;
    const phis = new Float64Array(n);
    const open = steps.map(() => null), dead = steps.map(() => null), undef = steps.map(() => null);
    const pairs = [], seen = new Set();
    for (const s of steps)
      for (const [p, q, what] of directions(s)) {
        const id = [p, q].sort().join(" ");
        if (!seen.has(id)) {
          seen.add(id);
          pairs.push({ s, p, q, what, least: Infinity, at: 0 });
        }
      }
    const guides = m.links.filter((l) => l.guide).map((l) => ({ l, p: l.guide[0], q: l.guide[1], least: Infinity }));
    const c = numbered(m);
    const gaps = [...pairs, ...guides].map((d) => ({ d, p: c.index(d.p), q: c.index(d.q) }));
    // The links held rigid at every `stride`-th angle, as check_rigidity (mjlink.reference) does
    // with check's angles: each pair of a link's points keeps its distance, and a sliding link
    // its angle to its guide.
    const stride = Math.max(1, Math.floor(n / 361));
    const rigid = m.links.map((l) => {
      const at = l.points.map(c.index);
      const pairs = [];
      for (let a = 0; a < at.length; a++) for (let b = a + 1; b < at.length; b++) pairs.push({ a, b, lo: Infinity, hi: -Infinity });
      return { l, at, pairs, guide: l.guide && l.points.length >= 2 ? l.guide.map(c.index) : null, start: 0, turn: 0 };
    });
    const slope = (P, p, q) => Math.atan2(P[q][1] - P[p][1], P[q][0] - P[p][0]);
    // A crank or attached point no block is built from and no direction or guide is drawn from
    // can neither fail to close nor pass a dead point, and is defined wherever the points it is
    // built from are and apart: it is solved only where the links are held rigid.
    const used = new Set([...gaps.flatMap((g) => [g.p, g.q]), ...c.steps.flatMap((s) => [s.pivot, s.a, s.b, s.origin, s.toward, s.start, ...(s.guide || [])])]);
    const every = c.steps.map((s) => s.kind === "dyad" || s.kind === "slider" || used.has(s.point));
    const P = c.ground.slice();
    let first = null;
    for (let i = 0; i < n; i++) {
      const phi = m.phi0 + (span * i) / (n - 1);
      const held = i % stride === 0;
      phis[i] = phi;
      for (let j = 0; j < steps.length; j++) {
        if (!held && !every[j]) continue;
        const s = c.steps[j];
        const r = BLOCKS[s.kind](s, P, phi * D, m.phi0 * D, L);
        P[s.point] = r.at;
        if (r.closes === false) (open[j] || (open[j] = new Uint8Array(n)))[i] = 1;
        else if (r.angle && r.angle.bad) (dead[j] || (dead[j] = new Uint8Array(n)))[i] = 1;
        if (undef[j] === null && !(Number.isFinite(r.at[0]) && Number.isFinite(r.at[1]) && Number.isFinite(r.at[2]))) undef[j] = phi;
      }
      for (const g of gaps) {
        const a = P[g.p], b = P[g.q];
        const dx = a[0] - b[0], dy = a[1] - b[1];
        const gap = Math.sqrt(dx * dx + dy * dy);
        const k = Number.isFinite(gap) ? gap : -1; // an undefined gap is the worst (check's argmin)
        if (k < g.d.least) {
          g.d.least = k;
          g.d.at = phi;
        }
      }
      if (i === 0) first = Object.fromEntries(c.names.map((k, x) => [k, P[x]]));
      if (held)
        for (const r of rigid) {
          for (const d of r.pairs) {
            const u = P[r.at[d.a]], w = P[r.at[d.b]];
            const dx = u[0] - w[0], dy = u[1] - w[1], dz = u[2] - w[2];
            const gap = Math.sqrt(dx * dx + dy * dy + dz * dz);
            if (gap < d.lo) d.lo = gap;
            if (gap > d.hi) d.hi = gap;
          }
          if (r.guide) {
            const rel = slope(P, r.at[0], r.at[1]) - slope(P, r.guide[0], r.guide[1]);
            if (i === 0) r.start = rel;
            const turn = Math.abs(Math.atan2(Math.sin(rel - r.start), Math.cos(rel - r.start)));
            if (turn > r.turn) r.turn = turn;
          }
        }
    }
    const wrap = (phi) => within(phi, span);
    const opened = steps.map((s, j) => open[j] && `${c.labels[j]} cannot close for input angles ${ranges(phis, open[j], span)} deg`).filter(Boolean);
    if (opened.length) return opened;
    const pair = pairs.find((d) => !(d.least >= L.direction_min));
    if (pair)
      return [
        `[[construct]] ${pair.s.point}: its ${pair.what} ${pair.p} and ${pair.q} come within ${Math.max(pair.least, 0).toPrecision(3)} mm ` +
          `of each other at input angle ${wrap(pair.at).toFixed(1)} deg, so the direction they define is undefined there`,
      ];
    const guide = guides.find((d) => !(d.least >= L.direction_min));
    if (guide)
      return [`[links.${guide.l.name}] guide: points ${guide.p} and ${guide.q} coincide (within ${L.direction_min} mm), so the guide has no direction`];
    const j = undef.findIndex((phi) => phi !== null);
    if (j >= 0) return [`[[construct]] ${steps[j].point}: the point is undefined at input angle ${wrap(undef[j]).toFixed(1)} deg`];
    for (const r of rigid) {
      const d = r.pairs.find((d) => d.hi - d.lo > 1e-9 * Math.max(d.hi, 1)); // mm: check_rigidity's rtol
      if (d) {
        out.push(
          `[links.${r.l.name}]: points ${r.l.points[d.a]} and ${r.l.points[d.b]} do not stay at a fixed distance ` +
            `(${d.lo.toFixed(4)}..${d.hi.toFixed(4)} mm): they are not on one rigid link`,
        );
        break;
      }
      if (r.turn > 1e-9) {
        out.push(`[links.${r.l.name}]: slides on ${r.l.guide[0]}-${r.l.guide[1]} but turns relative to that guide`);
        break;
      }
    }
    const near = (() => {
      for (const l of m.links)
        for (let a = 0; a < l.points.length; a++)
          for (let b = a + 1; b < l.points.length; b++) {
            const u = first[l.points[a]], w = first[l.points[b]];
            const gap = Math.hypot(u[0] - w[0], u[1] - w[1], u[2] - w[2]);
            if (gap > 0 && gap < L.distinct_min)
              return `[links.${l.name}]: points ${l.points[a]} and ${l.points[b]} are only ${gap.toPrecision(3)} mm apart (one point, or at least ${L.distinct_min} mm apart)`;
          }
      return null;
    })();
    if (near) out.push(near);
    steps.forEach((s, k) => {
      if (dead[k]) out.push(`${c.labels[k]} passes its dead-point limit for input angles ${ranges(phis, dead[k], span)} deg`);
    });
    return out;
  }

  // ------------------------------------------------------------------------- editing
  function set(m, path, value) {
    const [section, name, key] = path.split(".");
    if (section === "ground") m.ground[name]["xyz".indexOf(key)] = value;
    else if (section === "construct") m.steps.find((s) => s.point === name)[key] = value;
    else if (path === "input.phi0") m.phi0 = value;
  }

  // A number as the file's reader reads it back: JavaScript's shortest text that gives the same
  // double (an integral value as an integer, which the reader takes as the number it is).
  function num(v) {
    return String(v);
  }

  // The file as it was read (`M.text`) with each number of `edits` (study path -> value, file
  // units) that differs from the file's written in its place and nothing else changed: its
  // comments, order and every other value's spelling kept. `M.edits` says where each number is
  // written (mjlink.pages.design.save_edits: the span replaced, and what stands before and after
  // a number the file did not write, such as a key a block left to its default).
  function saved(M, edits) {
    const todo = Object.entries(edits)
      .filter(([p, v]) => M.edits[p] !== undefined && v !== get(M.model, p))
      .map(([p, v]) => ({ ...M.edits[p], value: num(v) }))
      .sort((a, b) => b.start - a.start);
    let text = M.text;
    for (const e of todo) text = text.slice(0, e.start) + e.before + e.value + e.after + text.slice(e.end);
    return text;
  }

  // --------------------------------------------------------------------------- the page
  const NS = "http://www.w3.org/2000/svg";
  const PER_TURN = 360; // samples per input turn: the study metrics' own (mjlink.analysis.summary)

  function svg(tag, attrs, parent) {
    const e = document.createElementNS(NS, tag);
    for (const k in attrs) e.setAttribute(k, attrs[k]);
    if (parent) parent.appendChild(e);
    return e;
  }

  function fmt(v) {
    return Math.abs(v) >= 1e4 ? v.toFixed(0) : Number(v.toPrecision(6)).toString();
  }

  function page(M) {
    const m = JSON.parse(JSON.stringify(M.model));
    const edits = {};
    const drawing = document.getElementById("drawing");
    const angle = document.getElementById("angle");
    const status = document.getElementById("status");
    const feed = document.getElementById("feed");
    const names = numbered(m); // the points' numbers in the samples: edits change no name
    let result = null;

    // The view box is the nominal design's extent, fixed: a dragged pivot moves on a still page.
    const first = metrics(m, 90);
    const all = first.samples.flatMap((s) => Object.values(s.P));
    const xs = all.map((p) => p[0]), ys = all.map((p) => p[1]);
    const span = Math.max(Math.max(...xs) - Math.min(...xs), Math.max(...ys) - Math.min(...ys)) || 1;
    const pad = 0.12 * span;
    const x0 = Math.min(...xs) - pad, y1 = Math.max(...ys) + pad;
    const w = Math.max(...xs) - Math.min(...xs) + 2 * pad, h = Math.max(...ys) - Math.min(...ys) + 2 * pad;
    drawing.setAttribute("viewBox", `${x0} ${-y1} ${w} ${h}`);
    const scale = span / 100; // stroke widths and labels in drawing units
    const layer = svg("g", { transform: "scale(1,-1)" }, drawing);

    // The design drawn: the last feasible one (`shown`), in colour while it is the design being
    // edited, greyed while the edited one is infeasible; the ground pivots always where they are
    // now, to be dragged. A geometry that does not close is never drawn: no position of it
    // would be true.
    let shown = null;
    function draw() {
      while (layer.firstChild) layer.removeChild(layer.firstChild);
      if (shown) {
        const fresh = shown.result === result;
        drawDesign(shown.m, shown.result, fresh ? layer : svg("g", { class: "stale" }, layer));
      }
      for (const g in m.ground) pivot(g);
    }

    function drawDesign(d, r, into) {
      const S = r.samples;
      for (const p of M.moving) {
        const i = names.index(p);
        const pts = S.map((s) => `${s.P[i][0]},${s.P[i][1]}`).join(" ");
        svg("polygon", { points: pts, fill: "none", stroke: p === d.key ? "#c2185b" : "#9e9e9e", "stroke-width": (p === d.key ? 0.5 : 0.25) * scale }, into);
      }
      const now = solve(d, Number(angle.value));
      if (d.thread) {
        const pts = d.thread.map((p) => `${now.P[p][0]},${now.P[p][1]}`).join(" ");
        svg("polyline", { points: pts, fill: "none", stroke: "#ef6c00", "stroke-width": 0.35 * scale }, into);
      }
      M.segments.forEach(([a, b], i) => {
        svg("line", { x1: now.P[a][0], y1: now.P[a][1], x2: now.P[b][0], y2: now.P[b][1], stroke: M.colors[i], "stroke-width": 0.9 * scale, "stroke-linecap": "round" }, into);
      });
      for (const p in now.P) {
        if (d.ground[p] === undefined && !M.coms.includes(p)) svg("circle", { cx: now.P[p][0], cy: now.P[p][1], r: 0.7 * scale, fill: "#fff", stroke: "#333", "stroke-width": 0.25 * scale }, into);
      }
      for (const p in now.P) {
        if (M.coms.includes(p)) continue;
        const t = svg("text", { x: now.P[p][0] + scale, y: -now.P[p][1] - scale, "font-size": 2.6 * scale, transform: "scale(1,-1)" }, into);
        t.textContent = p;
      }
    }

    function pivot(g) {
      const c = svg("circle", { cx: m.ground[g][0], cy: m.ground[g][1], r: 1.6 * scale, fill: "#1565c0", "fill-opacity": 0.35, stroke: "#1565c0", "stroke-width": 0.3 * scale, class: "pivot", "data-pivot": g }, layer);
      c.addEventListener("pointerdown", (ev) => {
        c.setPointerCapture(ev.pointerId);
        const move = (e) => {
          const pt = drawing.createSVGPoint();
          pt.x = e.clientX;
          pt.y = e.clientY;
          const q = pt.matrixTransform(drawing.getScreenCTM().inverse());
          change(`ground.${g}.x`, round(q.x), true);
          change(`ground.${g}.y`, round(-q.y), true);
          update();
        };
        const up = () => {
          c.removeEventListener("pointermove", move);
          c.removeEventListener("pointerup", up);
        };
        c.addEventListener("pointermove", move);
        c.addEventListener("pointerup", up);
      });
    }

    // A dragged coordinate to 0.001 mm: what the saved file holds, and what the page computes.
    const round = (v) => Math.round(v * 1000) / 1000;

    function change(path, value, fromDrag) {
      set(m, path, value);
      edits[path] = value;
      if (fromDrag) {
        const field = document.querySelector(`input[data-param="${path}"]`);
        if (field) field.value = fmt(value);
      }
    }

    // The numbers of the design being edited; while it is infeasible, the last feasible design's,
    // greyed and marked stale (its `data-value` empty: no number of the edited design is shown).
    function update() {
      const t0 = performance.now();
      result = metrics(m, PER_TURN);
      const found = problems(m);
      result.feasible = found.length === 0;
      result.why = found.join("; ");
      if (result.feasible) shown = { m: JSON.parse(JSON.stringify(m)), result };
      const stale = !result.feasible && shown !== null;
      for (const el of document.querySelectorAll("[data-metric]")) {
        const v = shown ? shown.result.values[el.dataset.metric] : undefined;
        el.textContent = v !== undefined && (result.feasible || stale) ? fmt(v) : "–";
        el.dataset.value = result.feasible && v !== undefined ? String(v) : ""; // full precision
        el.dataset.feasible = String(result.feasible);
        el.classList.toggle("stale", stale);
        el.title = stale ? "the last feasible design's: the edited one is infeasible" : "";
      }
      status.textContent = result.feasible ? "assembles over the whole cycle, clear of dead points" : `infeasible: ${result.why}`;
      document.getElementById("stale-note").textContent = stale
        ? "Drawn greyed, numbers in grey: the last feasible design, kept while this one is infeasible."
        : "";
      status.className = result.feasible ? "ok" : "bad";
      caption();
      draw();
      if (feed && shown && shown.result.thread) plotThread(shown.result, stale);
      else if (feed) feed.innerHTML = "";
      document.body.dataset.updateMs = (performance.now() - t0).toFixed(2);
      document.body.dataset.updates = String(Number(document.body.dataset.updates || 0) + 1);
    }

    function caption() {
      const stale = !result.feasible && shown !== null;
      document.getElementById("angle-value").textContent = `${angle.value} deg` + (stale ? " (the last feasible design)" : "");
      document.getElementById("angle-value").classList.toggle("stale", stale);
    }

    function plotThread(r, stale) {
      feed.innerHTML = "";
      feed.classList.toggle("stale", stale);
      const lf = r.thread, n = lf.length;
      const lo = Math.min(...lf), hi = Math.max(...lf);
      feed.setAttribute("viewBox", `0 0 ${n} 100`);
      const pts = lf.map((v, i) => `${i},${95 - (90 * (v - lo)) / (hi - lo || 1)}`).join(" ");
      svg("polyline", { points: pts, fill: "none", stroke: "#ef6c00", "stroke-width": 1.2, "vector-effect": "non-scaling-stroke" }, feed);
      const range = document.getElementById("feed-range");
      range.textContent = `${fmt(lo)} .. ${fmt(hi)} mm over ${m.turns * 360} deg from phi0` + (stale ? " (the last feasible design)" : "");
      range.classList.toggle("stale", stale);
    }

    for (const field of document.querySelectorAll("input[data-param]")) {
      if (M.edits[field.dataset.param] === undefined) {
        // A number whose place in the file the page could not find is not edited: a saved file
        // would not hold it.
        field.disabled = true;
        field.title = "written in the file in a way the page cannot edit in place: edit the file";
        continue;
      }
      field.addEventListener("input", () => {
        const v = Number(field.value);
        if (field.value.trim() === "" || !Number.isFinite(v)) return;
        change(field.dataset.param, v, false);
        update();
      });
    }
    angle.addEventListener("input", () => {
      caption();
      draw();
    });
    document.getElementById("save").addEventListener("click", () => {
      const text = saved(M, edits);
      document.getElementById("toml").value = text;
      const a = document.createElement("a");
      a.href = URL.createObjectURL(new Blob([text], { type: "application/toml" }));
      a.download = `${M.model.name}.toml`;
      document.body.appendChild(a);
      a.click();
      a.remove();
    });
    update();
    document.body.dataset.ready = "true";
  }

  window.mjlinkDesign = { solve, metrics, refused, problems, set, saved, BLOCKS, page };
  const data = document.getElementById("mechanism-data");
  if (data) page(JSON.parse(data.textContent));
})();
