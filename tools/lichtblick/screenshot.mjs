#!/usr/bin/env node
// Screenshot a Lichtblick web build connected to a Foxglove WebSocket server, with a layout.
//
// usage: node screenshot.mjs WEB_URL WS_URL LAYOUT_JSON OUT_PNG WAIT_SECONDS [--console PATH]
//   WEB_URL      where the static Lichtblick build is served, e.g. http://127.0.0.1:8080/
//   WS_URL       Foxglove WebSocket server, e.g. ws://127.0.0.1:8765
//   LAYOUT_JSON  layout file (Lichtblick/Foxglove "Export layout" format)
//   OUT_PNG      screenshot (1600x1000)
//   WAIT_SECONDS how long to let data flow after the connection is seen, before the screenshot
//   --console    where browser console messages go (default: console.log beside OUT_PNG)
//
// Prints one JSON object to stdout, the evidence an automated check can assert on:
//   ok                      the script ran to the end
//   connected               the Topics sidebar listed topics and no "ws:connection-failed" player
//                           alert was logged before the screenshot
//   layout_loaded           every panel id of the layout's configById is on screen
//   topics                  [[topic, schema, frequency, count], ...] as the Topics sidebar shows them
//   panels[]                id, box, text (title, legend), legend_values {label: current value}
//                           (Plot panels with showPlotValuesInLegend), pixels (distinct colours in
//                           the screenshot region), log_count/logs (the panel's own log messages)
//   alerts_text             the Alerts sidebar after the screenshot
//   player_alerts_logged    player alerts seen in the console; console_counts; ws_frames_received
// Exit 0 when connected, 3 when not, 1 on error. The screenshot is taken WAIT_SECONDS after the
// topics appeared (the capture itself takes about a second).
//
// The layout is handed to the app via its `layoutUrl` URL parameter; the URL points at a path on
// the web origin that this script answers itself (request interception), so nothing needs to be
// copied into the web folder. Only loopback hosts are ever contacted: the browser resolves every
// other host name to nothing, and any request to a non-loopback host is aborted.

import fs from "node:fs";
import path from "node:path";
import { chromium } from "playwright-core";

const LAYOUT_ROUTE = "__screenshot_layout__/layout.json";
const LOOPBACK = new Set(["127.0.0.1", "localhost", "[::1]", "::1"]);
const isLoopback = (host) => LOOPBACK.has(host) || /^127\.\d+\.\d+\.\d+$/.test(host);

function usage(msg) {
  if (msg) console.error(msg);
  console.error(
    "usage: node screenshot.mjs WEB_URL WS_URL LAYOUT_JSON OUT_PNG WAIT_SECONDS [--console PATH]",
  );
  process.exit(1);
}

const argv = process.argv.slice(2);
let consolePath;
const ci = argv.indexOf("--console");
if (ci >= 0) {
  consolePath = argv[ci + 1];
  argv.splice(ci, 2);
}
if (argv.length !== 5) usage();
const [webArg, wsUrl, layoutPath, outPng, waitArg] = argv;
const waitSeconds = Number(waitArg);
if (!Number.isFinite(waitSeconds) || waitSeconds < 0) usage("WAIT_SECONDS must be a number >= 0");
const webUrl = new URL(webArg);
const ws = new URL(wsUrl);
if (!isLoopback(webUrl.hostname) || !isLoopback(ws.hostname)) usage("only loopback URLs allowed");
const layoutText = fs.readFileSync(layoutPath, "utf8");
JSON.parse(layoutText); // fail early on a broken layout
consolePath ??= path.join(path.dirname(path.resolve(outPng)), "console.log");

const executablePath = process.env.CHROMIUM_PATH ?? "/usr/bin/chromium";
const t0 = Date.now();
const elapsed = () => ((Date.now() - t0) / 1000).toFixed(1);
const steps = {};
const mark = (name) => (steps[name] = Number(elapsed()));

// ---- console capture -------------------------------------------------------------------------
const consoleLines = [];
const seen = new WeakSet();
const counts = { error: 0, warning: 0, other: 0, pageerror: 0, requestfailed: 0, blocked: 0 };
function logLine(kind, text) {
  consoleLines.push(`[${elapsed()}s] ${kind}: ${text}`);
}
function onConsole(origin) {
  return (msg) => {
    if (seen.has(msg)) return;
    seen.add(msg);
    const type = msg.type();
    if (type === "error") counts.error++;
    else if (type === "warning") counts.warning++;
    else counts.other++;
    const loc = msg.location();
    const where = loc?.url ? ` (${loc.url.split("/").pop()}:${loc.lineNumber})` : "";
    logLine(`${origin} ${type}`, `${msg.text()}${where}`);
  };
}

const browser = await chromium.launch({
  executablePath,
  headless: true,
  args: [
    "--no-sandbox",
    // No GPU process rasterising through SwiftShader (that made each screenshot take 10-30 s on
    // 2 cores while the 3-D panel renders); WebGL still gets SwiftShader, the rest is software.
    "--disable-gpu",
    "--enable-unsafe-swiftshader",
    "--host-resolver-rules=MAP * ~NOTFOUND, EXCLUDE localhost, EXCLUDE 127.0.0.1",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-domain-reliability",
    "--disable-sync",
    "--no-first-run",
    "--no-pings",
    "--disable-features=Translate,OptimizationHints,MediaRouter,AutofillServerCommunication",
  ],
});

let exitCode = 1;
const result = {
  ok: false,
  connected: false,
  web_url: webUrl.href,
  ws_url: wsUrl,
  layout: path.resolve(layoutPath),
  screenshot: path.resolve(outPng),
  console_log: path.resolve(consolePath),
};

try {
  const context = await browser.newContext({
    viewport: { width: 1600, height: 1000 },
    deviceScaleFactor: 1,
    serviceWorkers: "block",
  });
  const layoutUrl = new URL(LAYOUT_ROUTE, webUrl).href;
  await context.route("**/*", async (route) => {
    const u = new URL(route.request().url());
    if (u.href.split("?")[0] === layoutUrl) {
      await route.fulfill({ status: 200, contentType: "application/json", body: layoutText });
    } else if ((u.protocol === "http:" || u.protocol === "https:") && !isLoopback(u.hostname)) {
      counts.blocked++;
      logLine("blocked", u.href);
      await route.abort("blockedbyclient");
    } else {
      await route.continue();
    }
  });

  const page = await context.newPage();
  page.on("console", onConsole("page"));
  page.on("worker", (w) => {
    logLine("worker", `started ${w.url()}`);
    w.on("console", onConsole("worker"));
  });
  page.on("pageerror", (err) => {
    counts.pageerror++;
    logLine("pageerror", err.stack ?? String(err));
  });
  page.on("requestfailed", (req) => {
    counts.requestfailed++;
    logLine("requestfailed", `${req.url()} ${req.failure()?.errorText ?? ""}`);
  });
  const sockets = [];
  page.on("websocket", (s) => {
    const rec = { url: s.url(), frames_received: 0, closed: false };
    sockets.push(rec);
    s.on("framereceived", () => rec.frames_received++);
    s.on("close", () => (rec.closed = true));
    s.on("socketerror", (e) => logLine("websocket error", e));
  });

  const appUrl = new URL(webUrl);
  appUrl.searchParams.set("ds", "foxglove-websocket");
  appUrl.searchParams.set("ds.url", wsUrl);
  appUrl.searchParams.set("layoutUrl", layoutUrl);
  appUrl.searchParams.set("openIn", "web");
  result.app_url = appUrl.href;
  await page.goto(appUrl.href, { waitUntil: "load", timeout: 60_000 });

  // The app is up once its sidebar tabs exist.
  await page.getByTestId("topics-left").waitFor({ timeout: 60_000 });
  result.app_loaded_after_s = Number(elapsed());

  // Open the Topics tab (if the left sidebar isn't already showing it) and wait for topics.
  const topicRows = page.getByTestId("topic-row");
  const openTab = async (testId) => {
    const tab = page.getByTestId(testId);
    if (!(await tab.isVisible().catch(() => false))) {
      await page.getByTestId("left-sidebar-button").click({ timeout: 30_000 });
    }
    const selected = await tab.getAttribute("aria-selected");
    const sidebarVisible = await page.getByTestId("sidebar-left").isVisible().catch(() => false);
    if (!(selected === "true" && sidebarVisible)) await tab.click();
  };
  await openTab("topics-left");
  const connectTimeout = Math.max(20, waitSeconds) * 1000;
  try {
    await topicRows.first().waitFor({ timeout: connectTimeout });
    result.connected_after_s = Number(elapsed());
  } catch {
    result.connected_after_s = null;
  }
  await page.waitForTimeout(1000);
  result.topics = (await topicRows.allInnerTexts()).map((t) => t.split("\n").filter(Boolean));
  mark("topics");

  // Close the left sidebar so the panels get the whole width, then let data flow.
  if (await page.getByTestId("sidebar-left").isVisible().catch(() => false)) {
    await page.getByTestId("left-sidebar-button").click({ timeout: 10_000 }).catch(() => {});
  }
  await page.mouse.move(800, 4); // park the pointer on the app bar (no hover tooltips)
  mark("sidebar_closed");
  const waitStart = Date.now();
  await page.waitForTimeout(waitSeconds * 1000);

  await page.screenshot({ path: outPng, fullPage: false, timeout: 60_000 });
  result.waited_s = Number(((Date.now() - waitStart) / 1000).toFixed(1));
  mark("screenshot");
  const connFailedBeforeShot = consoleLines.some((l) => /ws:connection-failed/.test(l));

  // Panels: the mosaic marks each panel with data-testid "panel-mouseenter-container <id>"
  // (e.g. "Plot!rotor"); take their text (toolbar title, legend with current values) and pixel
  // statistics of what they drew in the screenshot just taken.
  const boxes = await page.evaluate(() =>
    [...document.querySelectorAll('[data-testid^="panel-mouseenter-container"]')].map((e) => {
      const r = e.getBoundingClientRect();
      return {
        id: e.getAttribute("data-testid").split(/\s+/)[1] ?? "",
        text: e.innerText,
        box: [Math.round(r.x), Math.round(r.y), Math.round(r.width), Math.round(r.height)],
      };
    }),
  );
  const pngB64 = fs.readFileSync(outPng).toString("base64");
  const stats = await page.evaluate(
    async ({ b64, rects }) => {
      const bytes = Uint8Array.from(atob(b64), (c) => c.charCodeAt(0));
      const bmp = await createImageBitmap(new Blob([bytes], { type: "image/png" }));
      const c = new OffscreenCanvas(bmp.width, bmp.height);
      const g = c.getContext("2d", { willReadFrequently: true });
      g.drawImage(bmp, 0, 0);
      return rects.map(([x, y, w, h]) => {
        if (w <= 0 || h <= 0) return null;
        const d = g.getImageData(x, y, w, h).data;
        const hist = new Map();
        for (let i = 0; i < d.length; i += 4) {
          const k = ((d[i] >> 3) << 10) | ((d[i + 1] >> 3) << 5) | (d[i + 2] >> 3);
          hist.set(k, (hist.get(k) ?? 0) + 1);
        }
        const n = d.length / 4;
        const top = Math.max(...hist.values());
        return {
          distinct_colors: hist.size,
          non_dominant_fraction: Number(((n - top) / n).toFixed(4)),
        };
      });
    },
    { b64: pngB64, rects: boxes.map((b) => b.box) },
  );
  result.panels = boxes.map((b, i) => {
    const lines = b.text
      .split("\n")
      .map((s) => s.trim())
      .filter(Boolean);
    // Plot legends with showPlotValuesInLegend: a label line followed by its current value.
    const values = {};
    for (let j = 0; j + 1 < lines.length; j++) {
      if (!/^-?[\d.]+(e[-+]?\d+)?$/i.test(lines[j]) && /^-?[\d.]+(e[-+]?\d+)?$/i.test(lines[j + 1])) {
        values[lines[j]] = Number(lines[j + 1]);
      }
    }
    return { id: b.id, box: b.box, text: lines.slice(0, 40), legend_values: values, pixels: stats[i] };
  });
  const expected = Object.keys(JSON.parse(layoutText).configById ?? {});
  result.layout_panels_missing = expected.filter((id) => !boxes.some((b) => b.id === id));
  mark("panels");

  // Panel logs (the red dot on a panel's "Show logs (N)" button): open them and read them.
  for (const p of result.panels) {
    const root = page.locator(`[data-testid~="${p.id}"]`).first();
    const btn = root.locator('button[title^="Show logs"], button[title^="Hide logs"]').first();
    const title = await btn.getAttribute("title", { timeout: 2000 }).catch(() => null);
    const m = /\((\d+)\)/.exec(title ?? "");
    p.log_count = m ? Number(m[1]) : 0;
    if (p.log_count > 0) {
      const before = new Set(p.text);
      await btn.click({ timeout: 10_000 }).catch(() => {});
      await page.waitForTimeout(700);
      const after = (await root.innerText().catch(() => "")).split("\n").map((x) => x.trim());
      p.logs = after.filter((x) => x && !before.has(x)).slice(0, 30);
      await btn.click({ timeout: 10_000 }).catch(() => {});
    }
  }
  mark("panel_logs");

  // Alerts (connection failures, schema/message parse errors, ...), read after the screenshot.
  await openTab("alerts-left");
  await page.waitForTimeout(500);
  result.alerts_text = (await page.getByTestId("sidebar-left").innerText().catch(() => ""))
    .split("\n")
    .map((s) => s.trim())
    .filter(Boolean);
  result.header_text = (await page.locator("header").first().innerText().catch(() => "")).trim();
  result.player_alerts_logged = consoleLines
    .filter((l) => /Player alert/.test(l))
    .map((l) => l.replace(/^\[[\d.]+s\] /, "").slice(0, 200));
  result.connection_failed_before_screenshot = connFailedBeforeShot;
  mark("alerts");
  // The app opens its socket in a worker; Chromium still reports it (one entry per attempt).
  result.websockets = sockets;
  result.ws_frames_received = sockets.reduce((a, s) => a + s.frames_received, 0);
  result.console_counts = counts;
  result.connected = result.topics.length > 0 && !connFailedBeforeShot;
  result.layout_loaded = expected.length > 0 && result.layout_panels_missing.length === 0;
  result.ok = true;
  exitCode = result.connected ? 0 : 3;
} catch (e) {
  result.error = String(e?.stack ?? e);
  exitCode = 1;
} finally {
  fs.writeFileSync(consolePath, consoleLines.join("\n") + "\n");
  await browser.close().catch(() => {});
}
result.elapsed_s = Number(elapsed());
result.steps_s = steps;
process.stdout.write(JSON.stringify(result, null, 2) + "\n");
process.exit(exitCode);
