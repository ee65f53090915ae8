// One viewer tab over its WebSocket, as the benchmark clients drive it (view_latency.mjs, view_rest_move.mjs): the
// messages it sent and when (a frame's status says which of them it reflects: "request" counts the accepted client
// messages, view_protocol.h), the scene's camera, the last status, and a wait for the next frame whose status passes a
// test. Needs node >= 20 with --experimental-websocket.
export class ViewSession {
  constructor(url) {
    this.ws = new WebSocket(url);
    this.ws.binaryType = "arraybuffer";
    this.sentAt = [];  // sentAt[k]: when the k-th accepted message was sent (hello is 1)
    this.accepted = 0;
    this.camera = null;  // the scene's, until the client moves it
    this.status = null;  // the status of the next binary frame
    this.onFrame = null;  // (status, now) => void, for every frame
    this.ws.onmessage = (ev) => {
      const now = performance.now();
      if (typeof ev.data === "string") {
        const m = JSON.parse(ev.data);
        if (m.type === "scene") this.camera = m.camera;
        else if (m.type === "status") this.status = m;
        else if (m.type === "error") console.error("server error:", m.message);
        return;
      }
      if (this.status && this.onFrame) this.onFrame(this.status, now);
    };
    this.ws.onerror = (e) => {
      console.error("websocket error", e.message || e);
      process.exit(1);
    };
  }
  // `body` once the socket is open.
  run(body) {
    this.ws.onopen = body;
  }
  send(msg) {
    this.ws.send(JSON.stringify(msg));
    this.accepted += 1;
    this.sentAt[this.accepted] = performance.now();
  }
  // The first frame from now on whose status passes `pred`: {st, now}.
  waitFor(pred) {
    return new Promise((resolve) => {
      this.onFrame = (st, now) => {
        if (pred(st, now)) {
          this.onFrame = null;
          resolve({ st, now });
        }
      };
    });
  }
  close() {
    this.ws.close();
  }
}

// The q-quantile of xs by the nearest rank (null for none).
export const percentile = (xs, q) => {
  const s = [...xs].sort((a, b) => a - b);
  return s.length ? s[Math.min(s.length - 1, Math.floor(q * (s.length - 1) + 0.5))] : null;
};
