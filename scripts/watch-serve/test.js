// Drives `tslc watch --serve` and a headless Chromium page through an edit
// that breaks the scene and one that fixes it. See ../test-watch-serve.sh.
"use strict";
const { chromium } = require("playwright-core");
const { spawn } = require("child_process");
const fs = require("fs");
const os = require("os");
const path = require("path");

const scene = (kd) => `import "lib.tsl";
material ball = lambert(kd: ${kd});
scene {
    camera { from (0, 1, -4); to (0, 1, 0); fov 40; }
    render { width 64; height 48; spp 64; }
    light point { at (2, 4, -3); intensity gray(60); }
    object sphere { center (0, 1, 0); radius 1; material ball; }
    object plane { point (0, 0, 0); normal (0, 1, 0); material lambert(kd: gray(level())); }
}
`;

let passed = 0;
let failed = 0;
function check(what, ok) {
    console.log(`${ok ? "ok    " : "FAILED"} ${what}`);
    if (ok) passed++; else failed++;
}

async function main() {
    const work = fs.mkdtempSync(path.join(os.tmpdir(), "tslc-watch-serve-"));
    const shots = path.resolve("target/watch-serve");
    fs.mkdirSync(shots, { recursive: true });
    fs.writeFileSync(path.join(work, "lib.tsl"), "float level() { return 0.5; }\n");
    fs.writeFileSync(path.join(work, "scene.tsl"), scene("rgb(0.8, 0.2, 0.1)"));

    const watch = spawn(process.env.TSLC, ["watch", "scene.tsl", "-o", "out.png", "--serve", "127.0.0.1:0"], {
        cwd: work,
        env: { ...process.env, NO_COLOR: "1" },
        stdio: ["ignore", "ignore", "pipe"],
    });
    let log = "";
    const url = await new Promise((resolve, reject) => {
        watch.stderr.on("data", (chunk) => {
            log += chunk;
            const m = log.match(/serving (http:\/\/\S+)/);
            if (m) resolve(m[1]);
        });
        watch.on("exit", () => reject(new Error("tslc watch exited:\n" + log)));
    });

    const browser = await chromium.launch({
        executablePath: process.env.CHROMIUM,
        args: ["--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
            "--disable-background-networking", "--disable-component-update", "--disable-sync"],
    });
    try {
        const page = await browser.newPage();
        await page.goto(url);
        await page.evaluate(() => { window.notReloaded = true; });
        const imageVersion = () => page.evaluate(() => Number(document.getElementById("image").dataset.version || 0));

        // The image refines: several passes reach the page, the last at 64 spp.
        await page.waitForFunction(() => document.getElementById("status").textContent.startsWith("64 / 64"),
            null, { timeout: 120000 });
        await page.waitForFunction(() => document.getElementById("image").naturalWidth === 64, null, { timeout: 10000 });
        const refined = await imageVersion();
        check(`the image refined in ${refined} passes and is shown at 64 x 48`, refined >= 2);
        await page.screenshot({ path: path.join(shots, "refined.png") });

        // A broken edit: the diagnostics appear, the image stays.
        fs.writeFileSync(path.join(work, "scene.tsl"), scene("rgb(0.8, 0.2"));
        await page.waitForFunction(() => document.getElementById("diagnostics").textContent.includes("could not check"),
            null, { timeout: 60000 });
        const text = await page.textContent("#diagnostics");
        check("the diagnostics name the file, line and column", /scene\.tsl:2:\d+/.test(text));
        const broken = await page.evaluate(() => ({
            shown: getComputedStyle(document.getElementById("diagnostics")).display !== "none",
            width: document.getElementById("image").naturalWidth,
        }));
        check("the diagnostics are shown and the last image stays", broken.shown && broken.width === 64);
        check("no new image came with the broken edit", (await imageVersion()) === refined);
        await page.screenshot({ path: path.join(shots, "broken.png") });

        // The fix: the diagnostics go away and the new render arrives.
        fs.writeFileSync(path.join(work, "scene.tsl"), scene("rgb(0.1, 0.3, 0.9)"));
        await page.waitForFunction((v) => Number(document.getElementById("image").dataset.version) > v &&
            document.getElementById("diagnostics").textContent === "", refined, { timeout: 60000 });
        await page.waitForFunction(() => document.getElementById("status").textContent.startsWith("64 / 64"),
            null, { timeout: 120000 });
        const hidden = await page.evaluate(() => getComputedStyle(document.getElementById("diagnostics")).display === "none");
        check("the fix clears the diagnostics and renders again", hidden);
        check("every update came without reloading the page", await page.evaluate(() => window.notReloaded === true));
        await page.screenshot({ path: path.join(shots, "fixed.png") });
    } finally {
        await browser.close();
        watch.kill();
        fs.rmSync(work, { recursive: true, force: true });
    }
    console.log(`watch-serve: ${passed} passed, ${failed} failed (screenshots in ${shots})`);
    process.exit(failed ? 1 : 0);
}

main().catch((e) => { console.error(e); process.exit(1); });
