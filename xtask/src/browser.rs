//! `cargo xtask browser`: the glTF export checked in a real browser (`docs/ENGINES.md`).
//!
//! 1. Bakes the Cornell box (draft) and, when `../shared` is there, the textured lava-circuit
//!    scene, exports both with `vlf-bake export` (Cornell box: exr and png-rgbm) and validates
//!    every GLB with Khronos's glTF-Validator (no error, no warning).
//! 2. Renders the page `web/index.html` (three.js from `web/node_modules`, `npm ci`) in headless
//!    Debian `chromium` with software WebGL (ANGLE on SwiftShader), served by a small HTTP
//!    server in this process; the page puts its canvas in the DOM (`--dump-dom`).
//! 3. Compares the canvas with `vlf-view --still` of the same camera, same size, tonemapped
//!    alike (clamp, exposure 0, sRGB), 1 sample per pixel: `vlf-bake compare` on the two PNGs
//!    (decoded to linear display values), mean HDR-FLIP within [`FLIP_BOUND`].
//! 4. Checks that the comparison can fail: the page without its lightmap bound, and with the
//!    EXR rows left bottom-up (a flipped V), must both exceed the bound.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, Result, bail};
use serde_json::Value;

use crate::ci::{cargo, step};

/// Mean HDR-FLIP of the browser's canvas against the viewer's still (EXR lightmap).
pub const FLIP_BOUND: f64 = 0.02;
/// The same for the RGBM lightmap (8-bit, filtered in its encoded form).
pub const FLIP_BOUND_RGBM: f64 = 0.04;
const SIZE: u32 = 256;
const WEB_DIR: &str = "web";
const CHROMIUM_HINT: &str = "install Debian's chromium: `apt-get install -y chromium` \
                             (xtask/bootstrap.sh does)";

pub fn browser(root: &Path) -> Result<()> {
    let out = root.join("target/browser");
    std::fs::create_dir_all(&out)?;
    // The binaries as the test step builds them (`cargo test` unifies the features of the
    // dev-dependencies too; `cargo build` would compile a second set): a no-op after it.
    step(
        "build vlf-bake and vlf-view",
        cargo(root).args(["test", "--workspace", "--no-run", "--quiet"]),
    )?;
    let bin = |name: &str| root.join("target/debug").join(name);
    let s = |p: &Path| p.to_str().map(str::to_owned).context("non-UTF-8 path");

    // 1. Bake, export, validate.
    let cornell = out.join("cornell-box.vlf");
    step(
        "bake the Cornell box (draft)",
        Command::new(bin("vlf-bake")).args([
            "-q",
            "bake",
            &s(&root.join("assets/cornell-box/cornell-box.gltf"))?,
            "-o",
            &s(&cornell)?,
            "--quality",
            "draft",
        ]),
    )?;
    let export = |vlf: &Path, glb: &Path, texture: &str| -> Result<()> {
        step(
            &format!("export {} ({texture})", glb.display()),
            Command::new(bin("vlf-bake")).args([
                "export",
                &s(vlf)?,
                "-o",
                &s(glb)?,
                "--texture",
                texture,
            ]),
        )
    };
    let glb = out.join("cornell-box.glb");
    let glb_rgbm = out.join("cornell-box-rgbm.glb");
    export(&cornell, &glb, "exr")?;
    export(&cornell, &glb_rgbm, "png-rgbm")?;
    let mut exported = vec![glb.clone(), glb_rgbm.clone()];
    let lava_scene = root.join("../shared/scenes/lava-circuit/DepthOfFieldExample.glb");
    if lava_scene.exists() {
        let lava = out.join("lava-circuit.vlf");
        // Coarse: this checks the export of a textured scene, not the bake's quality.
        step(
            "bake lava-circuit (coarse)",
            Command::new(bin("vlf-bake")).args([
                "-q",
                "bake",
                &s(&lava_scene)?,
                "-o",
                &s(&lava)?,
                "--quality",
                "draft",
                "--final-gather",
                "off",
                "--directions",
                "21",
                "--resolution",
                "16",
                "--iterations",
                "1",
            ]),
        )?;
        let lava_glb = out.join("lava-circuit.glb");
        export(&lava, &lava_glb, "exr")?;
        exported.push(lava_glb);
    } else {
        eprintln!(
            "NOTE: {} not found: the textured lava-circuit export is NOT checked",
            lava_scene.display()
        );
    }
    crate::validate::validate_gltf(root, &exported)?;

    // 2. The viewer's still.
    let still = out.join("cornell-still.png");
    step(
        "vlf-view still of the glTF camera",
        Command::new(bin("vlf-view")).args([
            &s(&cornell)?,
            "--still",
            &s(&still)?,
            "--camera",
            "0",
            "--size",
            &format!("{SIZE}x{SIZE}"),
            "--spp",
            "1",
            "--tonemap",
            "clamp",
            "--exposure",
            "0",
        ]),
    )?;

    // 3. The page in chromium.
    ensure_web_installed(root)?;
    let server = Server::start(root)?;
    let rel = |p: &Path| -> Result<String> {
        Ok(p.strip_prefix(root)
            .context("output outside the repository")?
            .to_str()
            .context("non-UTF-8 path")?
            .to_owned())
    };
    let cases = [
        ("exr", rel(&glb)?, "", Some(FLIP_BOUND)),
        ("png-rgbm", rel(&glb_rgbm)?, "", Some(FLIP_BOUND_RGBM)),
        ("no lightmap bound", rel(&glb)?, "lightmap", None),
        ("flipped V", rel(&glb)?, "flipv", None),
    ];
    let mut failures = Vec::new();
    for (name, file, brk, bound) in cases {
        let png = out.join(format!("browser-{}.png", name.replace(' ', "-")));
        let url = format!(
            "http://127.0.0.1:{}/{WEB_DIR}/index.html?file=/{file}&size={SIZE}x{SIZE}&still=1\
             &tonemap=clamp&exposure=0&break={brk}",
            server.port
        );
        render_page(&url, &png)?;
        let flip = compare(root, &png, &still)?;
        match bound {
            Some(b) => {
                let ok = flip <= b;
                eprintln!(
                    "browser {name}: mean FLIP {flip:.4} against the still (bound {b}): {}",
                    if ok { "ok" } else { "FAILED" }
                );
                if !ok {
                    failures.push(format!("{name}: mean FLIP {flip:.4} > {b}"));
                }
            }
            None => {
                let caught = flip > FLIP_BOUND_RGBM;
                eprintln!(
                    "browser, broken on purpose ({name}): mean FLIP {flip:.4}: {}",
                    if caught {
                        "fails the bound, as it must"
                    } else {
                        "PASSES the bound: the check is blind to it"
                    }
                );
                if !caught {
                    failures.push(format!("{name} is not caught (mean FLIP {flip:.4})"));
                }
            }
        }
    }
    if !failures.is_empty() {
        bail!("browser check failed:\n  {}", failures.join("\n  "));
    }
    eprintln!("browser: all checks passed (images in {})", out.display());
    Ok(())
}

/// Runs chromium headless on `url` and writes the canvas the page put in `data-png` to `png`.
fn render_page(url: &str, png: &Path) -> Result<()> {
    let profile = std::env::temp_dir().join(format!("vlf-chromium-{}", std::process::id()));
    let output = Command::new("chromium")
        .args([
            "--headless",
            "--no-sandbox",
            "--use-gl=angle",
            "--use-angle=swiftshader",
            "--enable-unsafe-swiftshader",
            "--disable-dev-shm-usage",
            "--no-first-run",
            &format!("--user-data-dir={}", profile.display()),
            &format!("--window-size={SIZE},{SIZE}"),
            "--virtual-time-budget=30000",
            "--dump-dom",
            url,
        ])
        .output();
    let _ = std::fs::remove_dir_all(&profile);
    let output = match output {
        Ok(o) => o,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            bail!("`chromium` was not found: {CHROMIUM_HINT}")
        }
        Err(e) => return Err(e).context("running chromium"),
    };
    let dom = String::from_utf8_lossy(&output.stdout);
    if let Some(err) = attribute(&dom, "data-error") {
        bail!("the page failed: {err} ({url})");
    }
    let Some(data) = attribute(&dom, "data-png") else {
        bail!(
            "the page did not finish ({url}; chromium {}):\n{}",
            output.status,
            String::from_utf8_lossy(&output.stderr)
                .lines()
                .filter(|l| !l.contains("dbus"))
                .collect::<Vec<_>>()
                .join("\n")
        );
    };
    let b64 = data
        .strip_prefix("data:image/png;base64,")
        .context("data-png is not a PNG data URL")?;
    std::fs::write(png, base64_decode(b64)?).with_context(|| format!("writing {}", png.display()))
}

/// `vlf-bake compare --json TEST REF`: the mean FLIP.
fn compare(root: &Path, test: &Path, reference: &Path) -> Result<f64> {
    let output = Command::new(root.join("target/debug/vlf-bake"))
        .arg("compare")
        .arg(test)
        .arg(reference)
        .arg("--json")
        .output()
        .context("running vlf-bake compare")?;
    if !output.status.success() {
        bail!(
            "vlf-bake compare failed: {}",
            String::from_utf8_lossy(&output.stderr)
        );
    }
    let v: Value = serde_json::from_slice(&output.stdout).context("compare --json output")?;
    v["flip_mean"]
        .as_f64()
        .context("compare --json has no flip_mean")
}

/// The value of `name="…"` in the dumped DOM (the page writes plain base64 or text into it).
fn attribute<'a>(dom: &'a str, name: &str) -> Option<&'a str> {
    let start = dom.find(&format!("{name}=\""))? + name.len() + 2;
    let len = dom[start..].find('"')?;
    Some(&dom[start..start + len])
}

fn base64_decode(s: &str) -> Result<Vec<u8>> {
    let value = |c: u8| -> Result<u32> {
        Ok(match c {
            b'A'..=b'Z' => u32::from(c - b'A'),
            b'a'..=b'z' => u32::from(c - b'a') + 26,
            b'0'..=b'9' => u32::from(c - b'0') + 52,
            b'+' => 62,
            b'/' => 63,
            _ => bail!("invalid base64 character {:?}", c as char),
        })
    };
    let bytes: Vec<u8> = s.bytes().filter(|c| *c != b'=').collect();
    let mut out = Vec::with_capacity(bytes.len() * 3 / 4);
    for chunk in bytes.chunks(4) {
        let mut n = 0u32;
        for (i, &c) in chunk.iter().enumerate() {
            n |= value(c)? << (18 - 6 * i);
        }
        let keep = chunk.len().saturating_sub(1);
        out.extend_from_slice(&n.to_be_bytes()[1..1 + keep]);
    }
    Ok(out)
}

/// Runs `npm ci` in `web/` unless its pinned three.js is installed.
fn ensure_web_installed(root: &Path) -> Result<()> {
    let (pinned, installed) = crate::validate::npm_pinned(&root.join(WEB_DIR), "three")?;
    if installed {
        return Ok(());
    }
    step(
        &format!("install three.js {pinned} (npm ci --prefix web)"),
        Command::new("npm")
            .args(["ci", "--prefix", WEB_DIR, "--no-audit", "--no-fund"])
            .current_dir(root),
    )
}

/// A static file server for the repository on a free local port (its thread ends with the
/// process).
struct Server {
    port: u16,
}

impl Server {
    fn start(root: &Path) -> Result<Self> {
        let listener = TcpListener::bind("127.0.0.1:0").context("binding a local port")?;
        let port = listener.local_addr()?.port();
        let root = root.to_path_buf();
        std::thread::spawn(move || {
            for stream in listener.incoming().flatten() {
                let root = root.clone();
                std::thread::spawn(move || {
                    let _ = serve(&root, stream);
                });
            }
        });
        Ok(Self { port })
    }
}

fn serve(root: &Path, mut stream: std::net::TcpStream) -> std::io::Result<()> {
    let mut reader = BufReader::new(stream.try_clone()?);
    let mut request = String::new();
    reader.read_line(&mut request)?;
    loop {
        let mut line = String::new();
        if reader.read_line(&mut line)? == 0 || line.trim().is_empty() {
            break;
        }
    }
    let path = request.split_whitespace().nth(1).unwrap_or("/");
    let path = path.split('?').next().unwrap_or("/");
    let file = resolve(root, path);
    let (status, body, mime) = match file.and_then(|f| {
        let mut body = Vec::new();
        std::fs::File::open(&f).ok()?.read_to_end(&mut body).ok()?;
        Some((body, mime(&f)))
    }) {
        Some((body, mime)) => ("200 OK", body, mime),
        None => ("404 Not Found", b"not found".to_vec(), "text/plain"),
    };
    write!(
        stream,
        "HTTP/1.1 {status}\r\nContent-Type: {mime}\r\nContent-Length: {}\r\nConnection: close\r\n\r\n",
        body.len()
    )?;
    stream.write_all(&body)?;
    stream.flush()
}

/// The file under `root` for a URL path; `None` for anything that climbs out of it.
fn resolve(root: &Path, url_path: &str) -> Option<PathBuf> {
    let mut p = root.to_path_buf();
    for part in url_path.split('/').filter(|s| !s.is_empty()) {
        if part == ".." || part.contains('\\') || part.contains('%') {
            return None;
        }
        p.push(part);
    }
    p.is_file().then_some(p)
}

fn mime(p: &Path) -> &'static str {
    match p.extension().and_then(|e| e.to_str()) {
        Some("html") => "text/html; charset=utf-8",
        Some("js" | "mjs") => "text/javascript",
        Some("json") => "application/json",
        Some("glb") => "model/gltf-binary",
        Some("png") => "image/png",
        _ => "application/octet-stream",
    }
}
