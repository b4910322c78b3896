// Resound Studio in a real browser (headless Debian chromium, driven by playwright-core):
// open the page, load the bundled recording, see its modes, hear it, solve a primitive, pick
// the hit point on it, estimate, save, audition the material on another shape, hear the render,
// and check that the WAV the page plays is the one `resound synth` writes for the same inputs.
//
// usage: node test.mjs RESOUND_BINARY SCREENSHOT_DIR
import { chromium } from "playwright-core";
import { spawn, execFileSync } from "node:child_process";
import { mkdirSync, mkdtempSync, writeFileSync, readFileSync, rmSync } from "node:fs";
import { tmpdir } from "node:os";
import { join } from "node:path";
import assert from "node:assert/strict";

const [bin, shots] = process.argv.slice(2);
if (!bin || !shots) {
  console.error("usage: node test.mjs RESOUND_BINARY SCREENSHOT_DIR");
  process.exit(2);
}
mkdirSync(shots, { recursive: true });
const work = mkdtempSync(join(tmpdir(), "resound-studio-browser-"));
const library = join(work, "lib.sqlite");
const step = (msg) => console.log(`browser: ${msg}`);

// The studio on any free port; it prints its address.
const server = spawn(bin, ["studio", "--port", "0", "--library", library], { stdio: ["ignore", "pipe", "inherit"] });
const url = await new Promise((resolve, reject) => {
  let out = "";
  server.stdout.on("data", (d) => {
    out += d;
    const m = out.match(/http:\/\/[0-9.:]+\//);
    if (m) resolve(m[0]);
  });
  server.on("exit", (code) => reject(new Error(`the studio exited (${code}) before listening`)));
  setTimeout(() => reject(new Error("the studio did not print its address in 60 s")), 60000);
});
step(`studio at ${url}`);

const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || "/usr/bin/chromium",
  args: [
    "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--autoplay-policy=no-user-gesture-required", "--disable-audio-output",
  ],
});
const problems = [];
let failed = false;
const page = await browser.newPage({ viewport: { width: 1280, height: 900 } });
try {
  page.on("pageerror", (e) => problems.push(`page error: ${e.message}`));
  // The refused second save (409) is provoked on purpose; any other error is a failure.
  page.on("console", (m) => {
    if (m.type() === "error" && !/status of 409/.test(m.text())) problems.push(`console: ${m.text()}`);
  });
  page.setDefaultTimeout(60000);
  const shot = async (name) => {
    await page.screenshot({ path: join(shots, `${name}.png`), fullPage: true });
    step(`screenshot ${name}.png`);
  };
  const status = () => page.locator("#status").textContent();
  const waitStatus = async (re, timeout = 600000) => {
    // Stops at a new error too, so a failed step says why at once instead of timing out (an
    // error already shown when the wait starts is the previous step's).
    const before = await status();
    await page.waitForFunction(([src, was]) => {
      const s = document.getElementById("status");
      return new RegExp(src).test(s.textContent) || (s.className === "error" && s.textContent !== was);
    }, [re.source, before], { timeout });
    assert.match(await status(), re);
    const s = await page.locator("#status").getAttribute("class");
    assert.notEqual(s, "error", `status is an error: ${await status()}`);
  };

  // 1. The page is interactive.
  const t0 = Date.now();
  await page.goto(url);
  await waitStatus(/^ready$/);
  const ready = Date.now() - t0;
  step(`page interactive in ${ready} ms`);

  // 2. The bundled recording: its strikes, modes and picture.
  await page.selectOption("#sample", "steel_nut_M4_2.wav");
  await page.click("#open-sample");
  await waitStatus(/^analysed steel_nut_M4_2\.wav: \d+ modes/);
  // The library's warnings reach the page (this recording's slow modes ring past the end).
  assert.match(await status(), /warning: .*damping is not determined/);
  assert.equal(await page.locator("#status").getAttribute("class"), "warn");
  const rows = await page.locator("#modes tbody tr").count();
  assert.ok(rows >= 3, `only ${rows} modes shown`);
  const firstF = Number(await page.locator("#modes tbody tr:first-child td:nth-child(2)").textContent());
  assert.ok(firstF > 20 && firstF < 22050, `first mode at ${firstF} Hz`);
  // Each mode says how sure it is (σ of f and d).
  assert.match(await page.locator("#modes tbody tr:first-child td:nth-child(3)").textContent(), /^±\d/);
  await page.waitForFunction(() => document.getElementById("spectrogram").naturalWidth > 0);
  assert.match(await page.locator("#conditioning").textContent(), /strike/);

  // Hear it: the clock advances and the analyser sees signal; switch to the modes mid-way
  // (the position carries over).
  await page.click('button[data-part="recording"]');
  await page.waitForFunction(() => window.studio.position() > 0.15, null, { timeout: 10000 });
  const heard = await page.evaluate(async () => {
    let peak = 0;
    for (let i = 0; i < 40; i++) { peak = Math.max(peak, window.studio.level()); await new Promise((r) => setTimeout(r, 10)); }
    return peak;
  });
  assert.ok(heard > 1e-4, `the analyser heard nothing (peak ${heard})`);
  const before = await page.evaluate(() => window.studio.position());
  await page.click('button[data-part="modes"]');
  const after = await page.evaluate(() => [window.studio.position(), window.studio.playing()]);
  assert.equal(after[1], "modes");
  assert.ok(after[0] >= before - 0.01, `A/B restarted: ${before} → ${after[0]}`);
  await page.click("#stop");
  await shot("1-recording");
  await page.evaluate(() => window.scrollTo(0, 0));
  await page.screenshot({ path: join(shots, "0-first-screen.png") });

  // 3. The object: the demo's bar, solved with a progress bar; a click on it picks the hit.
  await page.selectOption("#kind", "bar");
  await page.fill("#sizes", "0.1,0.03,0.005");
  await page.fill("#nmodes", "40");
  await page.click("#solve");
  await page.locator("#solve-job").waitFor({ state: "visible" });
  await waitStatus(/^solved: 40 modes/);
  const box = await page.locator("#view").boundingBox();
  const hitBefore = await page.inputValue("#hit");
  await page.locator("#view").click({ position: { x: box.width / 2, y: box.height / 2 } });
  const picked = await page.inputValue("#hit");
  assert.notEqual(picked, hitBefore, "a click on the object picked no hit point");
  assert.equal(picked.split(",").length, 3);
  await page.selectOption("#shape-mode", "1");
  await page.waitForFunction(() => window.studio.state.surface && window.studio.state.surface.displacement);
  // Hear the shown mode alone, as the audition's material makes it sound at the hit.
  await page.click("#hear-mode");
  await waitStatus(/^object mode 1: \d/);
  assert.match(await page.locator("#mode-info").textContent(), /dB re the loudest mode/);
  await page.waitForFunction(() => window.studio.playing() === "object mode 1" && window.studio.position() > 0.05, null, { timeout: 10000 });
  await page.click("#stop");
  await page.locator("#object-step").screenshot({ path: join(shots, "2-object-mode.png") });
  // The demo's hit point, typed.
  await page.fill("#hit", "0.02,0.01,0.0025");
  await page.locator("#hit").dispatchEvent("change");
  await shot("2-object");

  // The page stays responsive during a long solve: while it runs, the server answers, a
  // recording plays and the page draws frames; the solve is still running after all of it
  // (an order, not a timing), and is then cancelled.
  await page.selectOption("#kind", "plate");
  await page.fill("#sizes", "0.3,0.2,0.003");
  await page.fill("#nmodes", "300");
  await page.click("#solve");
  await page.locator("#solve-job").waitFor({ state: "visible" });
  const during = await page.evaluate(async () => {
    const t = performance.now();
    const ok = (await fetch("/api/materials")).ok;
    const answer = performance.now() - t;
    let frames = 0, gap = 0, last = performance.now();
    await new Promise((done) => {
      const tick = (now) => { frames++; gap = Math.max(gap, now - last); last = now; if (frames < 20) requestAnimationFrame(tick); else done(); };
      requestAnimationFrame(tick);
    });
    return { ok, answer, frames, gap };
  });
  await page.click('button[data-part="recording"]');
  await page.waitForFunction(() => window.studio.position() > 0.1, null, { timeout: 10000 });
  await page.click("#stop");
  assert.ok(during.ok && during.frames === 20);
  assert.equal(await page.locator("#solve-job").isVisible(), true, "the solve ended before the checks: make it longer");
  await page.click("#solve-job .cancel");
  await waitStatus(/cancelled/);
  step(`during a 300-mode solve: /api/materials answered in ${during.answer.toFixed(0)} ms, 20 frames with the longest gap ${during.gap.toFixed(0)} ms, the recording played`);
  // 4. Estimate, then save under a name; saving again is refused until "replace" is ticked.
  // First on a thin 0.3 m rod, far from the recording's ramp: matching its modes needs a γ no
  // solid has, so the fit is refused as not credible, with how to keep it.
  await page.selectOption("#kind", "bar");
  await page.fill("#sizes", "0.3,0.01,0.01");
  await page.fill("#nmodes", "40");
  await page.click("#solve");
  await waitStatus(/^solved: 40 modes/);
  await page.fill("#hit", "0.02,0,0.005");
  await page.locator("#hit").dispatchEvent("change");
  await page.click("#estimate");
  await page.waitForFunction(() => /the estimate is not credible/.test(document.getElementById("status").textContent), null, { timeout: 600000 });
  assert.equal(await page.locator("#status").getAttribute("class"), "error");
  assert.match(await page.locator("#status").textContent(), /outside the range of solids/);
  assert.match(await page.locator("#status").textContent(), /tick "keep a fit that is not credible"/);
  assert.match(await page.locator("#estimate-refused").textContent(), /recorded modes paired/);
  assert.equal(await page.locator("#estimate-refused").isVisible(), true);
  assert.equal(await page.locator("#estimated").isVisible(), false);
  await page.locator("#material-step").screenshot({ path: join(shots, "3-material-refused.png") });
  step("an estimate on a rod that is not the recorded object: refused as not credible, with how to keep it");
  // Then on the demo's stand-in bar, kept when asked: 40 modes pair much of the recording
  // wherever γ puts them, so the status line warns that the pairing is mostly chance and the
  // report says what chance pairs.
  await page.fill("#sizes", "0.1,0.03,0.005");
  await page.click("#solve");
  await waitStatus(/^solved: 40 modes/);
  await page.fill("#hit", "0.02,0.01,0.0025");
  await page.locator("#hit").dispatchEvent("change");
  await page.check("#keep-implausible");
  await page.click("#estimate");
  await waitStatus(/^estimated in/);
  assert.equal(await page.locator("#status").getAttribute("class"), "warn");
  assert.match(await page.locator("#status").textContent(), /mostly chance/);
  assert.equal(await page.locator("#estimate-refused").isVisible(), false);
  assert.match(await page.locator("#estimate-report").textContent(), /gamma/);
  assert.match(await page.locator("#estimate-report").textContent(), /% by chance/);
  await page.waitForFunction(() => document.getElementById("estimate-plot").naturalWidth > 0);
  await page.fill("#save-name", "studio-ramp");
  await page.click("#save");
  await waitStatus(/^saved studio-ramp/);
  await page.click("#save");
  await page.waitForFunction(() => /replace/.test(document.getElementById("status").textContent));
  assert.equal(await page.locator("#status").getAttribute("class"), "error");
  await page.check("#replace");
  await page.click("#save");
  await waitStatus(/^saved studio-ramp/);
  assert.ok(await page.locator("#library td", { hasText: "studio-ramp" }).count() > 0);
  await shot("3-material");

  // 5. Audition on another shape: a plate, hit where a click lands.
  await page.selectOption("#kind", "plate");
  await page.fill("#sizes", "0.2,0.15,0.004");
  await page.fill("#nmodes", "30");
  await page.click("#solve");
  await waitStatus(/^solved: 30 modes/);
  const pbox = await page.locator("#view").boundingBox();
  await page.locator("#view").click({ position: { x: pbox.width * 0.45, y: pbox.height * 0.45 } });
  const hit = (await page.evaluate(() => window.studio.state.hit)).map(Number);
  // A second click, with "the microphone" chosen, puts the microphone 0.3 m out from the
  // clicked face, outside the plate.
  await page.check('input[name="click-sets"][value="mic"]');
  await page.locator("#view").click({ position: { x: pbox.width * 0.55, y: pbox.height * 0.5 } });
  await waitStatus(/^microphone at /);
  const mic = await page.evaluate(() => {
    const s = window.studio.state;
    return { mic: s.mic, from: s.micFrom, bbox: s.surface.bbox_m };
  });
  assert.ok(Math.abs(Math.hypot(...mic.mic.map((x, c) => x - mic.from[c])) - 0.3) < 1e-9);
  const inside = (q, e) => q.every((x, c) => x >= mic.bbox[0][c] - e && x <= mic.bbox[1][c] + e);
  assert.ok(inside(mic.from, 1e-9) && !inside(mic.mic, 0.25), `microphone ${mic.mic} from ${mic.from}`);
  await page.check('input[name="click-sets"][value="hit"]');
  const micArg = (await page.inputValue("#mic")).trim();
  await page.selectOption("#audition-material", "studio-ramp");
  await page.click("#render");
  await waitStatus(/^rendered studio-ramp/);
  await page.waitForFunction(() => window.studio.position() > 0.1, null, { timeout: 10000 });
  const level = await page.evaluate(async () => {
    let peak = 0;
    for (let i = 0; i < 40; i++) { peak = Math.max(peak, window.studio.level()); await new Promise((r) => setTimeout(r, 10)); }
    return peak;
  });
  assert.ok(level > 1e-4, `the render was not heard (peak ${level})`);
  await page.click("#renders button:has-text('compare')");
  await page.waitForFunction(() => document.querySelector("#renders .distance").textContent !== "–");
  // Both spectrograms side by side.
  await page.waitForFunction(() => ["cmp-recording", "cmp-render"].every((id) => document.getElementById(id).naturalWidth > 0));
  await shot("4-audition");

  // 6. The WAV the page plays is the one the CLI writes for the same inputs.
  const ids = await page.evaluate(() => [window.studio.state.object.id, window.studio.state.renders[0].id]);
  const fetchBytes = (path) => page.evaluate(async (p) => Array.from(new Uint8Array(await (await fetch(p)).arrayBuffer())), path);
  const served = Buffer.from(await fetchBytes(`/api/renders/${ids[1]}.wav`));
  const model = join(work, "plate.rmodal");
  writeFileSync(model, Buffer.from(await fetchBytes(`/api/objects/${ids[0]}/model.rmodal`)));
  const cli = join(work, "cli.wav");
  execFileSync(bin, ["synth", "--material", "studio-ramp", "--library", library, "--mesh", model,
    "--hit", hit.map(String).join(","), "--mic", micArg, "--velocity", "1", "--duration", "2", "-o", cli], { stdio: "inherit" });
  assert.ok(served.equals(readFileSync(cli)), "the studio's WAV differs from resound synth's");
  step("the served WAV equals resound synth's byte for byte");

  // 7. Rename it in the library (the page asks for the new name).
  page.once("dialog", (d) => d.accept("studio-ramp-2"));
  await page.locator("#library tr", { hasText: "studio-ramp" }).locator("button:has-text('rename')").click();
  await waitStatus(/^renamed studio-ramp to studio-ramp-2$/);
  assert.equal(await page.locator("#library td", { hasText: /^studio-ramp$/ }).count(), 0);
  assert.equal(await page.locator("#library td", { hasText: /^studio-ramp-2$/ }).count(), 1);

  // 7b. Keep a statistics file in the library: listed in the page and by the CLI, served back
  // byte for byte.
  const statsFile = join(work, "tin.stats.json");
  writeFileSync(statsFile, JSON.stringify({ material: "tin", modes: 1, mean: [7, -20, -60], covariance: [0.1, 0, 0, 0, 4, 0, 0, 0, 25], sources: 2 }));
  await page.setInputFiles("#keep-file", statsFile);
  await waitStatus(/^kept statistics tin: tin: 1 modes/);
  assert.equal(await page.locator("#kept td", { hasText: /^tin$/ }).count(), 1);
  const listed = execFileSync(bin, ["materials", "list", "--library", library]).toString();
  assert.match(listed, /tin\s+statistics/);
  const back = Buffer.from(await fetchBytes("/api/library/files/statistics/tin"));
  assert.ok(back.equals(readFileSync(statsFile)), "the kept file changed");
  await page.locator("#library-step").screenshot({ path: join(shots, "6-library.png") });

  // 8. A drop test of the material, with its event log on a timeline.
  await page.fill("#drop-count", "3");
  await page.selectOption("#drop-material", "studio-ramp-2");
  await page.click("#drop");
  await waitStatus(/^rendered the drop: \d+ events/);
  const impacts = await page.evaluate(() => window.studio.state.scene.events.filter((e) => e.kind === "impact").length);
  assert.ok(impacts >= 3, `only ${impacts} impacts in the drop`);
  await page.waitForFunction(() => window.studio.position() > 0.1, null, { timeout: 10000 });
  await page.locator("#scene-step").screenshot({ path: join(shots, "5-scene.png") });
  step("screenshot 5-scene.png");

  // Every download the page offers is served, with the type its name says.
  const links = await page.evaluate(() => [...document.querySelectorAll("a[href^='/api/']")].map((a) => a.getAttribute("href")));
  assert.ok(links.length >= 10, `only ${links.length} download links`);
  const types = { wav: "audio/wav", png: "image/png", rmodal: "application/octet-stream", json: "application/json", grains: "application/octet-stream" };
  for (const href of links) {
    const got = await page.evaluate(async (h) => { const r = await fetch(h); return { ok: r.ok, type: r.headers.get("content-type"), size: (await r.arrayBuffer()).byteLength }; }, href);
    assert.ok(got.ok && got.size > 0, `${href}: ${JSON.stringify(got)}`);
    const ext = href.split("?")[0].split(".").pop();
    if (types[ext]) assert.ok(got.type.startsWith(types[ext]), `${href} is ${got.type}`);
  }
  step(`${links.length} download links served`);

  assert.deepEqual(problems, [], problems.join("\n"));
  step(`passed (page interactive in ${ready} ms)`);
} catch (e) {
  failed = true;
  console.error(`browser test failed: ${e.stack || e}`);
  await page.screenshot({ path: join(shots, "failure.png"), fullPage: true }).catch(() => {});
  console.error(`status: ${await page.locator("#status").textContent().catch(() => "?")}; see ${join(shots, "failure.png")}`);
  if (problems.length) console.error(problems.join("\n"));
} finally {
  await browser.close();
  server.kill();
  rmSync(work, { recursive: true, force: true });
}
process.exit(failed ? 1 : 0);
