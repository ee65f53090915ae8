// ugvr view: the time panel of a time series (docs/viewer.md, docs/time-series.md). Hidden unless the scene has a
// time axis of more than one step ("time": {"count", "times", "step"}, view_protocol.h). A slider over the steps and
// a label (step i of n, t = time), play/pause, loop and a rate in steps per second. A step change is one
// {"type":"time","step":N,"playing":B} message, queued like app.js's own so that a slider drag sends one message per
// animation frame (the latest step). Playing advances one step once the frame of the current step has been drawn,
// never faster than the frames come back, so steps are not skipped and no requests pile up; at the end it stops, or
// with loop starts again at step 0. The steps are paced by when their frames are shown, not by when they were asked
// for: the next step is asked for 1/rate seconds after the current one was shown, less the time a step's frame takes
// to come back (measured, averaged), so that frames appear 1/rate apart however long each took (paced by the
// requests, a slow frame after a quick one would show late by the difference). Loaded after vec.js and
// before app.js, whose queue() it calls when the user acts or a frame arrives (app.js calls ugvrTime.onScene and
// ugvrTime.onFrame).
'use strict';

const ugvrTime = (() => {
  let times = [];  // the steps' times (empty: no time axis)
  let step = 0;    // the step asked for last
  let shown = -1;  // the step of the last frame drawn (status.time_step)
  let playing = false;
  let loop = true;
  let rate = 5;         // steps per second while playing
  let lastAdvance = 0;  // performance.now() of the last step played
  let shownAt = 0;      // performance.now() when the frame of the step asked for last was shown (playing)
  let latency = 0;      // seconds from asking for a step to its frame shown, averaged over the steps played
  let wake = null;      // the timeout of the next advance
  let sent = 0;         // time messages queued (for the test hook)
  let panel = null;
  let timer = null;

  const $ = (cls) => panel.querySelector(cls);

  function label() {
    if (!panel) return;
    const t = times[step];
    $('.time-label').textContent =
        times.length ? `step ${step + 1} of ${times.length}, t = ${Number(t.toPrecision(4))}` : '';
    $('.time-play').textContent = playing ? 'pause' : 'play';
  }

  function go(i) {
    step = i;
    if (panel) $('.time-slider').value = String(i);
    label();
    queue({type: 'time', step, playing});
    sent++;
  }

  // Called on a timer and after every frame while playing.
  function advance() {
    if (!playing || shown !== step) return;  // the current step's frame is not drawn yet
    const now = performance.now();
    // The next frame should be shown 1/rate after this one: ask for it that long after this one was shown, less
    // the time a frame takes to come back (at once when that is longer than 1/rate).
    const due = shownAt + 1000 / rate - 1000 * latency;
    if (now < due) {
      clearTimeout(wake);
      wake = setTimeout(advance, due - now);
      return;
    }
    if (step + 1 >= times.length) {
      if (!loop) {
        setPlaying(false);
        return;
      }
      lastAdvance = now;
      go(0);
      return;
    }
    lastAdvance = now;
    go(step + 1);
  }

  function setPlaying(on) {
    playing = on && times.length > 1;
    clearInterval(timer);
    clearTimeout(wake);
    shownAt = 0, latency = 0;
    timer = playing ? setInterval(advance, 20) : null;
    // The server reads the next step ahead only while the page plays: tell it either way (a scene without a time
    // axis rejects the message).
    if (times.length)
      go(step);
    else
      label();
  }

  function row(labelText, ...controls) {
    const r = document.createElement('div');
    r.className = 'row';
    const l = document.createElement('label');
    l.textContent = labelText;
    r.append(l, ...controls);
    return r;
  }

  function build() {
    const host = document.getElementById('panel');
    if (!host || panel) return;
    panel = document.createElement('div');
    panel.id = 'time';
    panel.hidden = true;
    const slider = document.createElement('input');
    Object.assign(slider, {type: 'range', min: 0, max: 0, step: 1, value: 0, className: 'time-slider'});
    slider.addEventListener('input', () => go(Number(slider.value)));
    const text = document.createElement('span');
    text.className = 'note time-label';
    const play = document.createElement('button');
    play.className = 'time-play';
    play.textContent = 'play';
    play.addEventListener('click', () => setPlaying(!playing));
    const loopBox = document.createElement('input');
    Object.assign(loopBox, {type: 'checkbox', checked: loop, className: 'time-loop'});
    loopBox.addEventListener('change', () => (loop = loopBox.checked));
    const loopLabel = document.createElement('label');
    loopLabel.append(loopBox, ' loop');
    const rateInput = document.createElement('input');
    Object.assign(rateInput, {type: 'number', min: 0.5, max: 60, step: 0.5, value: rate, className: 'time-rate'});
    rateInput.title = 'steps per second while playing';
    rateInput.addEventListener('change', () => {
      const v = Number(rateInput.value);
      if (v > 0 && v <= 60)
        rate = v;
      else
        rateInput.value = String(rate);
    });
    panel.append(row('time', slider), row('', text), row('', play, loopLabel, rateInput, ' steps/s'));
    // Above the engine row: the time axis is what a user of a series reaches for first.
    host.insertBefore(panel, host.firstChild);
    label();
  }

  document.addEventListener('DOMContentLoaded', build);
  if (document.readyState !== 'loading') build();

  return {
    // A scene message: shows the panel for a series of more than one step, starting at the scene's step.
    onScene(m) {
      build();
      const first = times.length === 0;
      times = m.time && m.time.count > 1 ? m.time.times.slice() : [];
      panel.hidden = times.length === 0;
      $('.time-slider').max = String(Math.max(0, times.length - 1));
      if (!times.length) {
        setPlaying(false);
        return;
      }
      if (first) {
        step = Math.min(m.time.step, times.length - 1);
        $('.time-slider').value = String(step);
        label();
        // `ugvr view --play R`: the page starts playing (looping) at R steps a second.
        if (m.time.play > 0) {
          rate = m.time.play;
          $('.time-rate').value = String(rate);
          setPlaying(true);
        }
      } else {
        go(Math.min(step, times.length - 1));  // a new scene: the tab asks for its step again
      }
    },
    // A frame was drawn (its status): playing moves on once the current step is on the canvas.
    onFrame(status) {
      if (!status || status.time_step === undefined) return;
      if (playing && status.time_step === step && shown !== step) {
        // The step asked for last is shown now: how long it took to come back.
        shownAt = performance.now();
        const took = (shownAt - lastAdvance) / 1000;
        latency = latency > 0 ? 0.7 * latency + 0.3 * took : took;
      }
      shown = status.time_step;
      advance();
    },
    go,
    play: () => setPlaying(true),
    pause: () => setPlaying(false),
    setRate(v) {
      rate = v;
      if (panel) $('.time-rate').value = String(v);
    },
    // Read-only state for tests/e2e.
    get state() {
      return {count: times.length, step, shown, playing, loop, rate, sent, hidden: !panel || panel.hidden};
    },
  };
})();
window.ugvrTime = ugvrTime;
