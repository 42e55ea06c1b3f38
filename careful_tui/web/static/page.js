// careful study in a browser: times each hold from keydown to keyup and draws what the server answers.
// The server runs the game: this page sends only keys (with their times on performance.now()'s clock,
// the events' timeStamp) and draws the views it gets back. Every text is set with textContent.
"use strict";
(() => {
  const ARROWS = { ArrowUp: "up", ArrowRight: "right", ArrowDown: "down", ArrowLeft: "left" };
  const ANGLE = { right: 0, down: 90, left: 180, up: 270 };
  const SYMBOL_CLASS = { ".": "sym-ground", C: "sym-C", G: "sym-G", U: "sym-U", "#": "sym-wall" };
  const LEVEL_STOPS = [[0x4f, 0xc3, 0xf7], [0xff, 0xd5, 0x4f], [0xff, 0x5a, 0x36]];
  const HEARTBEAT_MS = 5000;
  const REDIRECT_MS = 1500;
  const RETRY_MS = 2000;
  const PROLIFIC = "https://app.prolific.com/";
  const state = { page: null, view: null, held: null, queue: Promise.resolve(), frame: 0, beat: 0, over: false, drawnRows: null };
  const $ = (id) => document.getElementById(id);

  function el(tag, className, text) {
    const node = document.createElement(tag);
    if (className) node.className = className;
    if (text !== undefined) node.textContent = text;
    return node;
  }

  function show(section) {
    for (const id of ["notice", "text", "play", "calib", "reach"]) $(id).hidden = id !== section;
  }

  function notice(title, text, button) {
    $("notice-title").textContent = title;
    $("notice-text").textContent = text;
    const b = $("notice-button");
    b.hidden = !button;
    if (button) { b.textContent = button.label; b.onclick = button.act; }
    $("keys").replaceChildren();
    show("notice");
  }

  function flash(text) { $("flash").textContent = text || ""; }

  function levelColour(level, levels) {
    const f = levels <= 1 ? 0 : Math.min(1, Math.max(0, (level - 1) / (levels - 1)));
    const x = f * (LEVEL_STOPS.length - 1);
    const i = Math.min(Math.floor(x), LEVEL_STOPS.length - 2);
    const t = x - i;
    const [a, b] = [LEVEL_STOPS[i], LEVEL_STOPS[i + 1]];
    return "rgb(" + a.map((p, k) => Math.round(p + (b[k] - p) * t)).join(", ") + ")";
  }

  // The level a hold of `ms` gets: the server's HoldProfile.level_for, with the timing it sent.
  function levelFor(ms, timing) {
    if (ms < timing.tap_ms) return 1;
    return Math.min(timing.levels, 2 + Math.floor((ms - timing.tap_ms) / timing.ms_per_level + 1e-9));
  }

  function gaugeFill(ms, timing) {
    const level = levelFor(ms, timing);
    const fill = ms < timing.tap_ms ? 1 + ms / timing.tap_ms : 2 + (ms - timing.tap_ms) / timing.ms_per_level;
    return { level, fill: Math.min(fill, level + 0.999, timing.levels) };
  }

  function credentials() {
    const link = location.pathname.match(/^\/p\/([A-Za-z0-9_-]+)$/);
    if (link) return { token: link[1] };
    const q = new URLSearchParams(location.search);
    return { prolific: { pid: q.get("PROLIFIC_PID") || "", study_id: q.get("STUDY_ID") || "", session_id: q.get("SESSION_ID") || "" } };
  }

  async function post(path, body) {
    const response = await fetch(path, {
      method: "POST", headers: { "Content-Type": "application/json" }, body: JSON.stringify(body),
      cache: "no-store", credentials: "same-origin",
    });
    let data = null;
    try { data = await response.json(); } catch (e) { data = null; }
    return { status: response.status, data };
  }

  // A device whose only pointer is a touch screen has, as a rule, no keyboard to hold keys on.
  function touchOnly() {
    return matchMedia("(any-pointer: coarse)").matches && !matchMedia("(any-pointer: fine)").matches;
  }

  async function start() {
    clearTimeout(state.retry);
    if (touchOnly()) {
      notice("This study needs a keyboard", "It is played by holding the arrow keys of a physical keyboard. " +
        "Please open your link again on a computer with a keyboard.");
      return;
    }
    let answer;
    try { answer = await post("/api/start", credentials()); } catch (e) {
      notice("The study cannot be reached", "Check your connection, then try again.", { label: "Try again", act: start });
      return;
    }
    const { status, data } = answer;
    if (status === 200) {
      state.page = data.page;
      draw(data.view);
      clearInterval(state.beat);
      state.beat = setInterval(heartbeat, HEARTBEAT_MS);
    } else if (status === 409) {
      // The other page may be this one before a reload, whose goodbye is still on its way: try again
      // now and then, so this page takes over as soon as the other one has closed.
      notice("The study is open somewhere else", data.error, { label: "Try again", act: start });
      clearTimeout(state.retry);
      state.retry = setTimeout(start, RETRY_MS);
    } else {
      notice("This page cannot start the study", (data && data.error) || "The server answered " + status + ".");
    }
  }

  async function heartbeat() {
    if (!state.page) return;
    try {
      const { status } = await post("/api/alive", { page: state.page });
      if (status === 410) lost();
    } catch (e) { flash("The study cannot be reached just now; check your connection."); }
  }

  function lost() {
    state.page = null;
    state.held = null;
    clearInterval(state.beat);
    if (!state.over) {
      notice("This page lost its place in the study", "What you played is kept. Reload the page to go on.",
        { label: "Reload", act: () => location.reload() });
    }
  }

  function send(body) {
    const page = state.page;
    if (!page) return;
    state.queue = state.queue.then(async () => {
      if (state.page !== page) return;
      const { status, data } = await post("/api/key", Object.assign({ page }, body));
      if (status === 200) { draw(data.view); return; }
      if (status === 410) { lost(); return; }
      if (status === 429) { state.held = null; drawHold(); }
      flash((data && data.error) || "The server answered " + status + ".");
    }).catch(() => flash("The study cannot be reached: your last key was not saved. Check your connection."));
  }

  function draw(view) {
    state.view = view;
    $("title").textContent = view.title;
    $("who").textContent = "participant " + view.participant;
    const keys = $("keys");
    keys.replaceChildren(...view.keys.map(([key, what]) => {
      const chip = el("span");
      chip.append(el("kbd", "", key), document.createTextNode(what));
      return chip;
    }));
    if (view.stage === "reach") drawReach(view.reach);
    else if (view.stage === "play") drawPlay(view.play);
    else if (view.stage === "calibration") drawCalibration(view.calibration);
    else drawText(view);
    if (view.stage === "left") { state.over = true; state.page = null; clearInterval(state.beat); }
    if (view.complete_url && view.complete_url.startsWith(PROLIFIC) && !state.over) {
      state.over = true;
      const link = el("a", "", "Go back to Prolific now");
      link.href = view.complete_url;
      const line = el("p");
      line.append(link);
      $("text").append(line);
      setTimeout(() => location.assign(view.complete_url), REDIRECT_MS);
    }
  }

  function drawText(view) {
    flash("");
    $("text").replaceChildren(...view.paragraphs.map((p) => el("p", p.tone, p.text)));
    show("text");
  }

  function drawPlay(play) {
    $("heading").textContent = play.heading;
    show("play");  // first, so the board is sized to the room it has
    if (state.drawnRows !== JSON.stringify([play.rows, play.care])) buildBoard(play);
    const board = $("board");
    for (const cell of board.querySelectorAll(".player, .arrow")) cell.remove();
    for (const cell of board.querySelectorAll(".slipped-to")) cell.classList.remove("slipped-to");
    if (play.player) cellAt(play.player).append(el("div", "player"));
    if (play.last_move && play.last_move.slipped) cellAt(play.last_move.to).classList.add("slipped-to");
    drawStatus(play);
    if (!play.live) state.held = null;
    drawHold();
  }

  function cellAt([r, c]) { return $("board").children[r * state.cols + c]; }

  function buildBoard(play) {
    const rows = play.rows.map((row) => Array.from(row));
    state.cols = rows[0].length;
    const board = $("board");
    sizeBoard();
    board.replaceChildren(...rows.flat().map((symbol) => {
      const node = el("div", "cell " + (SYMBOL_CLASS[symbol] || "sym-other"), symbol === "." ? "" : symbol);
      node.title = symbol;
      return node;
    }));
    // The terminal's legend in the same words: name, reward (when the study shows rewards), "(ends)".
    $("legend").replaceChildren(...play.legend.map(([symbol, name, reward, ends]) => {
      const item = el("span");
      const words = symbol + " " + name + (reward === null ? "" : " " + reward) + (ends ? " (ends)" : "");
      item.append(el("span", "swatch " + (SYMBOL_CLASS[symbol] || "sym-other")), document.createTextNode(words));
      return item;
    }));
    buildGauge($("gauge"), play.levels);
    $("gauge").hidden = $("gauge-caption").hidden = play.care === "time";
    $("side").classList.toggle("time", play.care === "time");
    state.drawnRows = JSON.stringify([play.rows, play.care]);
  }

  // A time world: no gauge and no level; an arrow of one length shows the direction held, and with show_hold the
  // milliseconds held so far.
  function drawTimedHold(play) {
    for (const arrow of $("board").querySelectorAll(".arrow")) arrow.remove();
    const held = state.held;
    if (!held || !play.player) return;
    const cell = parseFloat(getComputedStyle($("board")).getPropertyValue("--cell")) || 56;
    const half = Math.max(3, Math.round(cell * 0.16));
    const length = cell * 0.6;
    const arrow = el("div", "arrow");
    const shaft = el("div", "shaft");
    shaft.style.width = Math.max(0, length - half) + "px";
    shaft.style.height = Math.max(2, Math.round(half * 0.66)) + "px";
    shaft.style.top = -Math.max(1, Math.round(half * 0.33)) + "px";
    shaft.style.background = "#555";
    const head = el("div", "head");
    head.style.left = Math.max(0, length - 1.5 * half) + "px";
    head.style.top = -half + "px";
    head.style.borderTopWidth = head.style.borderBottomWidth = half + "px";
    head.style.borderLeftWidth = 1.5 * half + "px";
    head.style.borderLeftColor = "#555";
    arrow.append(shaft, head);
    arrow.style.transform = "rotate(" + ANGLE[held.key] + "deg)";
    cellAt(play.player).append(arrow);
    $("hold-info").textContent = play.show_hold ? "held " + Math.round(performance.now() - held.t) + " ms" : "holding…";
    state.frame = requestAnimationFrame(drawHold);
  }

  function buildGauge(gauge, rows) {
    gauge.replaceChildren();
    const levels = rows.length;
    for (const row of [...rows].reverse()) {
      const bar = el("span", "bar");
      const fill = el("span", "fill");
      fill.style.background = levelColour(row.level, levels);
      bar.append(fill);
      gauge.append(el("span", "num", String(row.level)), bar, el("span", "cost", row.cost), el("span", "slip", row.slip),
        el("span", "mark", ""));
    }
  }

  // `now` ({level, fill}) on a gauge built by buildGauge.
  function fillGauge(gauge, levels, now) {
    const cells = gauge.children;
    for (let i = 0; i < levels; i++) {
      const level = levels - i;
      const part = Math.min(1, Math.max(0, now.fill - (level - 1)));
      cells[i * 5 + 1].firstChild.style.width = (part * 100).toFixed(1) + "%";
      const current = level === now.level;
      for (const k of [0, 2, 3]) cells[i * 5 + k].classList.toggle("current", current);
      cells[i * 5 + 4].textContent = current ? "◀" : "";
      cells[i * 5 + 4].style.color = levelColour(level, levels);
    }
  }

  // The calibration block: the level asked for, the gauge (filled by drawHold while a key is held), the last result.
  function drawCalibration(calib) {
    show("calib");
    $("calib-heading").textContent = calib.heading;
    $("calib-intro").textContent = calib.intro;
    const gauge = $("calib-gauge");
    if (gauge.dataset.levels !== String(calib.levels.length)) {
      buildGauge(gauge, calib.levels);
      gauge.dataset.levels = String(calib.levels.length);
    }
    // The level asked for stands out on the gauge (rows run from the top level down).
    const rows = calib.levels.length;
    for (let i = 0; i < rows; i++) gauge.children[i * 5].classList.toggle("asked", rows - i === calib.target);
    const lines = [el("p", calib.done ? "good" : "target", calib.instruction)];
    lines.push(el("p", "", calib.done ? `Press space to ${calib.begin}.` : ""));
    lines[1].id = "calib-now";
    if (calib.last && !calib.done) lines.push(el("p", "dim", "Last: " + calib.last));
    $("calib-text").replaceChildren(...lines);
    if (calib.done) state.held = null;
    drawHold();
  }

  // Cells as large as the room allows (down to 6 px, so a 128-column world still fits a phone's
  // width); again whenever the window changes size.
  function sizeBoard() {
    if (!state.cols) return;
    const board = $("board");
    const largest = parseFloat(getComputedStyle(document.documentElement).getPropertyValue("--cell-max")) || 64;
    const room = Math.max(160, $("right").clientWidth || window.innerWidth - 40);
    const gap = room / state.cols >= 26 ? 2 : 1;
    const cell = Math.max(6, Math.min(largest, Math.floor((room - gap * (state.cols - 1)) / state.cols)));
    board.style.setProperty("--cell", cell + "px");
    board.style.gap = gap + "px";
    board.style.gridTemplateColumns = "repeat(" + state.cols + ", var(--cell))";
  }
  window.addEventListener("resize", sizeBoard);

  function drawStatus(play) {
    const status = $("status");
    const lines = [];
    const head = el("p");
    head.append(el("strong", "", play.episode), el("span", "sep", "step " + play.step + "/" + play.max_steps),
      el("span", "sep", "score "));
    head.lastChild.append(el("span", "score " + (play.score_low ? "low" : "high"), play.score));
    if (play.end) {
      const code = play.end.code === "G" ? "end-G" : ["quit", "step_limit", "unfinished"].includes(play.end.code) ? "end-note" : "end-bad";
      const ended = el("p");
      ended.append(el("strong", "", play.episode + ": "), el("span", code, play.end.text + "!"),
        el("span", "sep", "score " + play.end.score));
      lines.push(ended);
      if (play.message) lines.push(el("p", "slip", play.message));
      lines.push(el("p", "dim", play.all_played ? "Press space to go on." : "Press space for the next episode."));
    } else {
      lines.push(head);
      lines.push(el("p", "slip", play.message || ""));
    }
    status.replaceChildren(...lines);
    const info = $("hold-info");
    if (!state.held) {
      const move = play.last_move;
      info.replaceChildren();
      if (move && play.care === "time") {
        info.append(document.createTextNode("last move: "), el("strong", "", move.direction),
          document.createTextNode((play.show_hold ? "\nheld " + Math.round(move.hold_ms) + " ms" : "") +
            (move.slipped ? (play.show_hold ? " · " : "\n") + "slipped " + move.realised : "")));
      } else if (move) {
        info.append(document.createTextNode("last move: "), el("strong", "", move.direction + " at level " + move.level),
          document.createTextNode("\nheld " + Math.round(move.hold_ms) + " ms" + (move.slipped ? " · slipped " + move.realised : "")));
      } else if (play.live && play.care === "time") {
        info.textContent = "Hold an arrow key: the longer you hold it, the more careful the move, and the more it costs.\nLet go to move.";
      } else if (play.live) {
        info.textContent = play.levels.length > 1 ? "Hold an arrow key: the longer you hold it, the more careful the move.\nLet go to move." : "Press an arrow key to move.";
      }
    }
  }

  // The gauge fills and the arrow on the player grows while a key is held.
  function drawHold() {
    cancelAnimationFrame(state.frame);
    const view = state.view;
    if (view && view.stage === "calibration") { drawCalibrationHold(view.calibration); return; }
    if (!view || view.stage !== "play") return;
    const play = view.play;
    if (play.care === "time") { drawTimedHold(play); return; }
    const gauge = $("gauge");
    const levels = play.levels.length;
    const held = state.held;
    const now = held ? gaugeFill(performance.now() - held.t, play.timing) : { level: 0, fill: 0 };
    fillGauge(gauge, levels, now);
    for (const arrow of $("board").querySelectorAll(".arrow")) arrow.remove();
    if (held && play.player) {
      const cell = parseFloat(getComputedStyle($("board")).getPropertyValue("--cell")) || 56;
      const arrow = el("div", "arrow");
      const length = cell * (0.35 + 0.9 * (now.fill - 1) / Math.max(1, levels - 1));
      const colour = levelColour(now.level, levels);
      const half = Math.max(3, Math.round(cell * 0.16));  // the head's half height, in step with the cell
      const shaft = el("div", "shaft");
      shaft.style.width = Math.max(0, length - half) + "px";
      shaft.style.height = Math.max(2, Math.round(half * 0.66)) + "px";
      shaft.style.top = -Math.max(1, Math.round(half * 0.33)) + "px";
      shaft.style.background = colour;
      const head = el("div", "head");
      head.style.left = Math.max(0, length - 1.5 * half) + "px";
      head.style.top = -half + "px";
      head.style.borderTopWidth = head.style.borderBottomWidth = half + "px";
      head.style.borderLeftWidth = 1.5 * half + "px";
      head.style.borderLeftColor = colour;
      arrow.append(shaft, head);
      arrow.style.transform = "rotate(" + ANGLE[held.key] + "deg)";
      cellAt(play.player).append(arrow);
      const info = $("hold-info");
      info.replaceChildren(document.createTextNode("level "), el("strong", "", String(now.level)),
        document.createTextNode("  cost " + play.levels[now.level - 1].cost + "  slip " + play.levels[now.level - 1].slip +
          "\nheld " + Math.round(performance.now() - held.t) + " ms"));
      state.frame = requestAnimationFrame(drawHold);
    }
  }

  function drawCalibrationHold(calib) {
    const held = state.held;
    const now = held ? gaugeFill(performance.now() - held.t, calib.timing) : { level: 0, fill: 0 };
    fillGauge($("calib-gauge"), calib.levels.length, now);
    const line = $("calib-now");
    if (line && !calib.done) line.textContent = held ? "Now: level " + now.level : "";
    if (held) state.frame = requestAnimationFrame(drawHold);
  }


  // ------------------------------------------------------------------ reach worlds
  // The field on a canvas. "simulated": the pointer aims, a press held times the reach (a ring of the endpoint's
  // sd shrinks while it is held), the release launches it. "own": the reach is the pointer's real movement, from
  // leaving the start to the button coming up; where the pointer is then is the endpoint. Times are the events'
  // timeStamps (performance.now()'s clock); the server words every result and refusal.
  const START_RADIUS = 10;  // field units: a reach begins when the pointer is this far from the start
  const reach = { pointer: null, held: null, own: null, path: [] };

  function regionColour(region) {
    if (region.points === null) return "rgba(158, 203, 255, 0.55)";
    const value = parseFloat(region.points.replace("−", "-"));
    return value > 0 ? "rgba(201, 162, 39, 0.6)" : value < 0 ? "rgba(200, 40, 40, 0.55)" : "rgba(120, 120, 170, 0.55)";
  }

  function fieldScale(view) {
    // As wide as the room, but short enough that the words under it stay in the window.
    const canvas = $("field");
    const room = canvas.parentElement.clientWidth || 640;
    const tall = Math.max(200, window.innerHeight - canvas.getBoundingClientRect().top - 150);
    const scale = Math.min(room / view.field[0], tall / view.field[1]);
    const ratio = window.devicePixelRatio || 1;
    const width = Math.round(view.field[0] * scale);
    const height = Math.round(view.field[1] * scale);
    if (canvas.width !== Math.round(width * ratio) || canvas.height !== Math.round(height * ratio)) {
      canvas.width = Math.round(width * ratio);
      canvas.height = Math.round(height * ratio);
      canvas.style.width = width + "px";
      canvas.style.height = height + "px";
    }
    return { scale, ratio };
  }

  function toField(event) {
    const view = state.view && state.view.reach;
    const rect = $("field").getBoundingClientRect();
    const scale = rect.width / view.field[0];
    const x = Math.min(Math.max((event.clientX - rect.left) / scale, 0), view.field[0]);
    const y = Math.min(Math.max((event.clientY - rect.top) / scale, 0), view.field[1]);
    return [x, y];
  }

  function reachSd(view, aim, ms) {
    const d = Math.min(Math.max(ms, view.min_ms), view.max_ms);
    const distance = Math.hypot(aim[0] - view.start[0], aim[1] - view.start[1]);
    return view.spread.a + view.spread.b * distance / (d / 1000);
  }

  function drawReach(view) {
    $("reach-heading").textContent = view.heading;
    $("reach-intro").textContent = view.intro;
    show("reach");
    if (view.done) { reach.held = null; reach.own = null; }
    paintField();
    const status = $("reach-status");
    const lines = [];
    const head = el("p");
    head.append(el("strong", "", (view.calibration ? "calibration reach " : "reach ") + view.trial + " of " + view.trials),
      el("span", "sep", view.calibration ? "" : "score " + view.score));
    lines.push(head);
    if (view.deadline_ms !== null && !view.done) lines.push(el("p", "deadline", "Take about " + Math.round(view.deadline_ms) + " ms."));
    if (view.message) lines.push(el("p", view.tone === "warn" ? "warn" : "", view.message));
    if (view.done) lines.push(el("p", "dim", "Press space to go on."));
    status.replaceChildren(...lines);
  }

  function paintField() {
    cancelAnimationFrame(state.frame);
    const view = state.view && state.view.reach;
    if (!view) return;
    const canvas = $("field");
    const { scale, ratio } = fieldScale(view);
    const g = canvas.getContext("2d");
    g.setTransform(ratio * scale, 0, 0, ratio * scale, 0, 0);
    g.clearRect(0, 0, view.field[0], view.field[1]);
    const px = 1 / scale;  // one CSS pixel in field units
    for (const region of view.regions) {
      g.beginPath();
      g.arc(region.centre[0], region.centre[1], region.radius, 0, 2 * Math.PI);
      g.fillStyle = regionColour(region);
      g.fill();
      g.lineWidth = 1.5 * px;
      g.strokeStyle = "rgba(255, 255, 255, 0.5)";
      g.stroke();
    }
    g.font = (14 * px) + "px system-ui, sans-serif";
    g.textAlign = "center";
    g.textBaseline = "middle";
    g.fillStyle = "#ffffff";
    // Each label pushed half a radius away from the circles' middle, so two overlapping circles' labels and an
    // endpoint at a centre do not cover one another.
    const middle = [0, 1].map((k) => view.regions.reduce((sum, r) => sum + r.centre[k], 0) / view.regions.length);
    for (const region of view.regions) {
      const label = region.symbol + (region.points === null ? "" : " " + region.points);
      const away = [region.centre[0] - middle[0], region.centre[1] - middle[1]];
      const length = Math.hypot(away[0], away[1]) || 1;
      const shift = view.regions.length > 1 ? region.radius * 0.5 / length : 0;
      g.fillText(label, region.centre[0] + away[0] * shift, region.centre[1] + away[1] * shift);
    }
    // The start: where every reach begins.
    g.beginPath();
    g.arc(view.start[0], view.start[1], START_RADIUS, 0, 2 * Math.PI);
    g.fillStyle = reach.own ? "rgba(126, 231, 135, 0.6)" : "rgba(207, 216, 227, 0.25)";
    g.fill();
    g.strokeStyle = "#cfd8e3";
    g.lineWidth = 1.5 * px;
    g.stroke();
    g.fillStyle = "#cfd8e3";
    // Above the start: below it the label ran off the field's edge (the built-in worlds start 20 units from it).
    g.fillText("start", view.start[0], view.start[1] - START_RADIUS - 12 * px);
    const last = view.last;
    if (last) {
      g.strokeStyle = "rgba(255, 255, 255, 0.35)";
      g.setLineDash([4 * px, 4 * px]);
      g.beginPath();
      g.moveTo(view.start[0], view.start[1]);
      g.lineTo(last.endpoint[0], last.endpoint[1]);
      g.stroke();
      g.setLineDash([]);
      cross(g, last.endpoint, 6 * px, "#ffffff", 2.5 * px);
    }
    if (view.noise === "own") {
      if (reach.own && reach.path.length > 1) {
        g.strokeStyle = "#7ee787";
        g.lineWidth = 2 * px;
        g.beginPath();
        g.moveTo(reach.path[0][0], reach.path[0][1]);
        for (const point of reach.path) g.lineTo(point[0], point[1]);
        g.stroke();
      }
      return;
    }
    const aim = reach.held ? reach.held.aim : reach.pointer || view.aim;
    plus(g, aim, 7 * px, "#9ecbff", 2 * px);
    if (reach.held) {
      const ms = performance.now() - reach.held.t;
      const within = ms < view.min_ms ? "short" : ms > view.max_ms ? "long" : "ok";
      g.beginPath();
      g.arc(aim[0], aim[1], reachSd(view, aim, ms), 0, 2 * Math.PI);
      g.strokeStyle = { short: "#ffd54f", ok: "#ffffff", long: "#ff6b6b" }[within];
      g.lineWidth = 2 * px;
      g.stroke();
      $("reach-status").firstChild.lastChild.textContent = "  held " + Math.round(ms) + " ms";
      state.frame = requestAnimationFrame(paintField);
    }
  }

  function cross(g, [x, y], r, colour, width) {
    g.strokeStyle = colour;
    g.lineWidth = width;
    g.beginPath();
    g.moveTo(x - r, y - r); g.lineTo(x + r, y + r);
    g.moveTo(x - r, y + r); g.lineTo(x + r, y - r);
    g.stroke();
  }

  function plus(g, [x, y], r, colour, width) {
    g.strokeStyle = colour;
    g.lineWidth = width;
    g.beginPath();
    g.moveTo(x - r, y); g.lineTo(x + r, y);
    g.moveTo(x, y - r); g.lineTo(x, y + r);
    g.stroke();
  }

  function reachLive() {
    const view = state.view;
    return Boolean(state.page && view && view.stage === "reach" && !view.reach.done);
  }

  $("field").addEventListener("pointerdown", (event) => {
    if (!reachLive() || event.button !== 0) return;
    event.preventDefault();
    const view = state.view.reach;
    const at = toField(event);
    $("field").setPointerCapture(event.pointerId);
    flash("");
    if (view.noise === "own") {
      if (Math.hypot(at[0] - view.start[0], at[1] - view.start[1]) > START_RADIUS) {
        flash("Press on the start to begin a reach.");
        return;
      }
      reach.own = { left: null };
      reach.path = [at];
      paintField();
      return;
    }
    reach.held = { t: stamp(event), aim: at };
    send({ type: "reach_press", aim: at, t: reach.held.t });
    paintField();
  });

  $("field").addEventListener("pointermove", (event) => {
    if (!reachLive()) return;
    const view = state.view.reach;
    const at = toField(event);
    if (view.noise === "own") {
      if (!reach.own) return;
      // The reach begins at the first event outside the start (its timeStamp: when the pointer was there).
      if (reach.own.left === null && Math.hypot(at[0] - view.start[0], at[1] - view.start[1]) > START_RADIUS) {
        reach.own.left = stamp(event);
      }
      reach.path.push(at);
      paintField();
      return;
    }
    if (!reach.held) { reach.pointer = at; paintField(); }
  });

  $("field").addEventListener("pointerup", (event) => {
    if (event.button !== 0) return;
    const view = state.view && state.view.reach;
    if (!view) return;
    const at = toField(event);
    if (reach.own) {
      const own = reach.own;
      reach.own = null;
      if (own.left === null) {
        flash("Move out of the start, then let go where the reach ends.");
        paintField();
        return;
      }
      send({ type: "reach_own", endpoint: at, duration_ms: stamp(event) - own.left });
      return;
    }
    if (reach.held) {
      reach.held = null;
      send({ type: "reach_release", t: stamp(event) });
      paintField();
    }
  });

  function reachFocusLost() {
    if (reach.own) { reach.own = null; paintField(); }
    if (reach.held) { reach.held = null; send({ type: "cancel" }); paintField(); }
  }
  // The browser took the pointer away (a touch turned into a scroll, a system gesture): no reach.
  $("field").addEventListener("pointercancel", reachFocusLost);
  window.addEventListener("resize", () => { if (state.view && state.view.stage === "reach") paintField(); });

  function stamp(event) { return event.timeStamp > 0 ? event.timeStamp : performance.now(); }

  function canMove() {
    const view = state.view;
    if (view && view.stage === "calibration") return Boolean(state.page && !view.calibration.done);
    return Boolean(state.page && view && view.stage === "play" && view.play.live);
  }

  addEventListener("keydown", (event) => {
    if (event.ctrlKey || event.metaKey || event.altKey) return;
    const key = ARROWS[event.key];
    if (key) {
      event.preventDefault();
      if (event.repeat || state.held || !canMove()) return;
      state.held = { key, t: stamp(event) };
      flash("");
      send({ type: "press", key, t: state.held.t });
      drawHold();
    } else if (event.key === " " || event.key === "Enter") {
      event.preventDefault();
      if (!event.repeat && !state.held) send({ type: "space" });
    } else if (event.key === "q" || event.key === "Q") {
      if (!event.repeat) { state.held = null; send({ type: "quit" }); }
    }
  });

  addEventListener("keyup", (event) => {
    const key = ARROWS[event.key];
    if (!key) return;
    event.preventDefault();
    const held = state.held;
    if (!held || held.key !== key) return;
    state.held = null;
    send({ type: "release", key, t: stamp(event) });
    drawHold();
  });

  // No keyup comes for a key let go in another window: a hold cut short by lost focus is no move.
  function focusLost() {
    reachFocusLost();
    if (!state.held) return;
    state.held = null;
    send({ type: "cancel" });
    drawHold();
  }
  addEventListener("blur", focusLost);
  document.addEventListener("visibilitychange", () => { if (document.hidden) focusLost(); else heartbeat(); });

  addEventListener("pagehide", () => {
    if (state.page) navigator.sendBeacon("/api/leave", JSON.stringify({ page: state.page }));
    state.page = null;
  });

  start();
})();
