//! `cargo xtask chart [--quick] [--redraw] [SCENE...]`: speed against accuracy on the shared
//! scenes (`docs/ACCURACY.md`). For each scene: run `vlf-bake sweep` (release build) against its Mitsuba 3
//! reference in ../shared/reference into docs/bench/chart/SCENE.csv, then
//! draw docs/bench/chart/SCENE-time.svg and SCENE-memory.svg (relMSE and FLIP against time and
//! against working memory, log-log) and write docs/bench/chart/summary.csv and summary.md (the
//! auto preset against the best grid point at the same bake time, the path tracer's time to
//! the same error, and the number of views at which the bake pays off).
//!
//! `--redraw` only redraws the charts and the summary from the CSVs already there.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};

use crate::ci::{cargo, step};

/// A scene of the chart: where it is, its reference and its view.
struct ChartScene {
    name: &'static str,
    file: &'static str,
    /// Its Mitsuba 3 reference under ../shared/reference, rendered from `view`.
    shared_ref: &'static str,
    /// `vlf-bake` view arguments (empty: the glTF camera 0).
    view: &'static [&'static str],
    /// Sweep grid when not `--quick`: `full`, or `quick` for a scene where the full grid would
    /// take too long (on the 2-core VM the full grids took 3.5, 4.5, 5 and 13 minutes).
    grid: &'static str,
    /// Also bake the high preset (minutes on a 2-core machine; only where it stays affordable).
    high: bool,
}

const SCENES: &[ChartScene] = &[
    ChartScene {
        name: "cornell-box",
        file: "cornell-box/cornell.gltf",
        shared_ref: "cornell-ref.exr",
        view: &[],
        grid: "full",
        high: true,
    },
    ChartScene {
        name: "cornell-box-mirror",
        file: "cornell-box-mirror/cornell-mirror.gltf",
        shared_ref: "cornell-mirror-ref.exr",
        view: &[],
        grid: "full",
        high: false,
    },
    // The files have no camera: the look-at views of ../shared/reference/README.md.
    ChartScene {
        name: "fog-room",
        file: "fog-room/VolumetricFogExample.glb",
        shared_ref: "fog-room-ref.exr",
        view: &[
            "--look-from",
            "2.8,3.0,0",
            // `=` so that clap does not read the negative coordinate as an option.
            "--look-at=-3,1,0",
            "--fov",
            "75",
        ],
        grid: "full",
        high: false,
    },
    ChartScene {
        name: "cornell-suzanne",
        file: "cornell-suzanne/cornellBox-2.80-Eevee-gltf.gltf",
        shared_ref: "cornell-suzanne-ref.exr",
        view: &[
            "--look-from",
            "0,1.5,6.5",
            "--look-at",
            "0,1.4,0",
            "--fov",
            "40",
        ],
        grid: "quick",
        high: false,
    },
    // Sky (1, 1, 1) only, through two windows; its glTF camera 0.
    ChartScene {
        name: "window-room",
        file: "window-room/window-room.glb",
        shared_ref: "window-room-ref.exr",
        view: &["--sky", "1,1,1"],
        grid: "quick",
        high: false,
    },
];

pub fn chart(root: &Path, args: &[String]) -> Result<()> {
    let quick = args.iter().any(|a| a == "--quick");
    let redraw = args.iter().any(|a| a == "--redraw");
    let wanted: Vec<&str> = args
        .iter()
        .filter(|a| !a.starts_with("--"))
        .map(String::as_str)
        .collect();
    for w in &wanted {
        if !SCENES.iter().any(|s| s.name == *w) {
            let names: Vec<&str> = SCENES.iter().map(|s| s.name).collect();
            bail!("unknown chart scene `{w}` (known: {})", names.join(", "));
        }
    }
    let scenes: Vec<&ChartScene> = SCENES
        .iter()
        .filter(|s| wanted.is_empty() || wanted.contains(&s.name))
        .collect();
    let shared = root.join("../shared");
    let out = root.join("docs/bench/chart");
    std::fs::create_dir_all(&out)?;
    if !redraw {
        step(
            "build vlf-bake (release)",
            cargo(root).args(["build", "--release", "-p", "vlf-bake"]),
        )?;
        let bin = root.join("target/release/vlf-bake");
        for s in &scenes {
            let scene_path = shared.join("scenes").join(s.file);
            let reference = shared.join("reference").join(s.shared_ref);
            let csv = out.join(format!("{}.csv", s.name));
            // The bakes run on the CPU reference propagator: on a machine whose only adapter
            // is lavapipe it is the faster path; on a hardware GPU drop `--device cpu`.
            let mut c = std::process::Command::new(&bin);
            c.args(["--device", "cpu", "sweep"])
                .arg(&scene_path)
                .arg("--reference")
                .arg(&reference)
                .arg("--csv")
                .arg(&csv)
                .args(["--grid", if quick { "quick" } else { s.grid }])
                .args(["--spp-max", if quick { "16" } else { "256" }])
                .args(s.view)
                // The references of these scenes shade every face flat
                // (../shared/reference/README.md; only lamp-room's uses its NORMALs).
                .arg("--flat-normals");
            if s.high && !quick {
                c.arg("--with-high");
            }
            step(&format!("sweep of {}", s.name), &mut c)?;
        }
    }
    let mut summary = Vec::new();
    for s in &scenes {
        let csv = out.join(format!("{}.csv", s.name));
        let rows = read_csv(&csv)?;
        for (axis, file) in [(Axis::Time, "time"), (Axis::Memory, "memory")] {
            let svg = draw(s.name, &rows, axis);
            let path = out.join(format!("{}-{file}.svg", s.name));
            std::fs::write(&path, svg).with_context(|| format!("writing {}", path.display()))?;
            eprintln!("wrote {}", path.display());
        }
        summary.push(summarize(s.name, &rows));
    }
    write_summary(&out, &summary)?;
    Ok(())
}

/// One CSV row, by column name.
#[derive(Clone, Debug)]
struct Row(BTreeMap<String, String>);

impl Row {
    fn s(&self, k: &str) -> &str {
        self.0.get(k).map_or("", String::as_str)
    }
    fn f(&self, k: &str) -> f64 {
        self.s(k).parse().unwrap_or(f64::NAN)
    }
}

fn read_csv(path: &Path) -> Result<Vec<Row>> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("reading {} (run `cargo xtask chart` first)", path.display()))?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines
        .next()
        .with_context(|| format!("{} is empty", path.display()))?
        .split(',')
        .collect();
    let mut rows = Vec::new();
    for (i, line) in lines.enumerate() {
        let cells: Vec<&str> = line.split(',').collect();
        if cells.len() != header.len() {
            bail!(
                "{} line {}: {} fields, header has {}",
                path.display(),
                i + 2,
                cells.len(),
                header.len()
            );
        }
        rows.push(Row(header
            .iter()
            .zip(cells)
            .map(|(h, c)| (h.to_string(), c.to_string()))
            .collect()));
    }
    Ok(rows)
}

#[derive(Clone, Copy, PartialEq)]
enum Axis {
    Time,
    Memory,
}

impl Axis {
    fn value(self, r: &Row) -> f64 {
        match self {
            Axis::Time => r.f("time_s"),
            Axis::Memory => r.f("work_bytes") / (1024.0 * 1024.0),
        }
    }
    fn label(self) -> &'static str {
        match self {
            Axis::Time => "time to produce the radiance (s)",
            Axis::Memory => "working memory (MiB)",
        }
    }
}

struct Series {
    name: String,
    color: &'static str,
    /// Points (x, y, label) in drawing order.
    points: Vec<(f64, f64, String)>,
    line: bool,
    marker: Marker,
}

#[derive(Clone, Copy)]
enum Marker {
    Circle,
    Square,
    Diamond,
    Triangle,
}

/// Lower-left Pareto front (min y for increasing x) of `pts`.
fn pareto(pts: &[(f64, f64, String)]) -> Vec<(f64, f64, String)> {
    let mut v: Vec<_> = pts.to_vec();
    v.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for p in v {
        if p.1 < best {
            best = p.1;
            front.push(p);
        }
    }
    front
}

fn series_for(rows: &[Row], axis: Axis, metric: &str) -> Vec<Series> {
    let pick = |method: &str| -> Vec<(f64, f64, String)> {
        rows.iter()
            .filter(|r| r.s("method") == method)
            .map(|r| (axis.value(r), r.f(metric), r.s("label").to_string()))
            .filter(|p| p.0 > 0.0 && p.1 > 0.0 && p.0.is_finite() && p.1.is_finite())
            .collect()
    };
    let vlf = pick("vlf");
    let presets: Vec<_> = rows
        .iter()
        .filter(|r| r.s("method") == "vlf" && !r.s("preset").is_empty())
        .map(|r| (axis.value(r), r.f(metric), r.s("preset").to_string()))
        .collect();
    let series = |name: &str, color, points, line, marker| Series {
        name: name.into(),
        color,
        points,
        line,
        marker,
    };
    let mut v = vec![
        series(
            "path tracer (1, 2, 4, … spp)",
            "#1f77b4",
            pick("pathtrace"),
            true,
            Marker::Circle,
        ),
        series(
            "VLF bake (grid)",
            "#ff7f0e",
            vlf.clone(),
            false,
            Marker::Square,
        ),
        series(
            "VLF best error for the cost",
            "#ff7f0e",
            pareto(&vlf),
            true,
            Marker::Square,
        ),
        series("VLF presets", "#d62728", presets, false, Marker::Diamond),
    ];
    // The light field alone (`--final-gather off`), and the radiosity baselines: their best
    // for the cost, then every point.
    for (method, name, all, color, marker) in [
        (
            "vlf-no-gather",
            "VLF without final gather",
            "(grid)",
            "#7f7f7f",
            Marker::Square,
        ),
        (
            "radiosity_gs",
            "radiosity GS",
            "(all points)",
            "#2ca02c",
            Marker::Triangle,
        ),
    ] {
        let points = pick(method);
        if !points.is_empty() {
            let front = format!("{name}, best for the cost");
            v.push(series(&front, color, pareto(&points), true, marker));
            v.push(series(
                &format!("{name} {all}"),
                color,
                points,
                false,
                marker,
            ));
        }
    }
    let jac = pick("radiosity_jacobi_gpu");
    if !jac.is_empty() {
        let name = "radiosity Jacobi (GPU)";
        v.push(series(name, "#17becf", jac, false, Marker::Triangle));
    }
    v
}

const W: f64 = 520.0;
const H: f64 = 400.0;
const ML: f64 = 70.0;
const MR: f64 = 20.0;
const MT: f64 = 40.0;
const MB: f64 = 55.0;

fn decades(lo: f64, hi: f64) -> (f64, f64) {
    let (mut a, mut b) = (lo.log10().floor(), hi.log10().ceil());
    if a == b {
        a -= 1.0;
        b += 1.0;
    }
    (a, b)
}

fn panel(svg: &mut String, x0: f64, title: &str, ylabel: &str, xlabel: &str, series: &[Series]) {
    let all: Vec<(f64, f64)> = series
        .iter()
        .flat_map(|s| s.points.iter().map(|p| (p.0, p.1)))
        .collect();
    if all.is_empty() {
        return;
    }
    let (xa, xb) = decades(
        all.iter().map(|p| p.0).fold(f64::INFINITY, f64::min),
        all.iter().map(|p| p.0).fold(0.0, f64::max),
    );
    let (ya, yb) = decades(
        all.iter().map(|p| p.1).fold(f64::INFINITY, f64::min),
        all.iter().map(|p| p.1).fold(0.0, f64::max),
    );
    let pw = W - ML - MR;
    let ph = H - MT - MB;
    let px = |x: f64| x0 + ML + (x.log10() - xa) / (xb - xa) * pw;
    let py = |y: f64| MT + ph - (y.log10() - ya) / (yb - ya) * ph;
    let _ = writeln!(
        svg,
        r##"<text x="{:.1}" y="22" font-size="15" text-anchor="middle" font-weight="bold">{}</text>"##,
        x0 + ML + pw / 2.0,
        esc(title)
    );
    let _ = writeln!(
        svg,
        r##"<rect x="{:.1}" y="{MT}" width="{pw}" height="{ph}" fill="none" stroke="#444"/>"##,
        x0 + ML
    );
    // Decade grid lines and labels, minor ticks at 2…9.
    for d in xa as i32..=xb as i32 {
        let x = px(10f64.powi(d));
        let _ = writeln!(
            svg,
            r##"<line x1="{x:.1}" y1="{MT}" x2="{x:.1}" y2="{:.1}" stroke="#ddd"/><text x="{x:.1}" y="{:.1}" font-size="11" text-anchor="middle">{}</text>"##,
            MT + ph,
            MT + ph + 16.0,
            pow10(d)
        );
        if d < xb as i32 {
            for m in 2..10 {
                let xm = px(f64::from(m) * 10f64.powi(d));
                let _ = writeln!(
                    svg,
                    r##"<line x1="{xm:.1}" y1="{:.1}" x2="{xm:.1}" y2="{:.1}" stroke="#888"/>"##,
                    MT + ph,
                    MT + ph - 4.0
                );
            }
        }
    }
    for d in ya as i32..=yb as i32 {
        let y = py(10f64.powi(d));
        let _ = writeln!(
            svg,
            r##"<line x1="{:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="#ddd"/><text x="{:.1}" y="{:.1}" font-size="11" text-anchor="end">{}</text>"##,
            x0 + ML,
            x0 + ML + pw,
            x0 + ML - 6.0,
            y + 4.0,
            pow10(d)
        );
        if d < yb as i32 {
            for m in 2..10 {
                let ym = py(f64::from(m) * 10f64.powi(d));
                let _ = writeln!(
                    svg,
                    r##"<line x1="{:.1}" y1="{ym:.1}" x2="{:.1}" y2="{ym:.1}" stroke="#888"/>"##,
                    x0 + ML,
                    x0 + ML + 4.0
                );
            }
        }
    }
    let _ = writeln!(
        svg,
        r##"<text x="{:.1}" y="{:.1}" font-size="12" text-anchor="middle">{}</text>"##,
        x0 + ML + pw / 2.0,
        H - 12.0,
        esc(xlabel)
    );
    let _ = writeln!(
        svg,
        r##"<text x="{:.1}" y="{:.1}" font-size="12" text-anchor="middle" transform="rotate(-90 {:.1} {:.1})">{}</text>"##,
        x0 + 18.0,
        MT + ph / 2.0,
        x0 + 18.0,
        MT + ph / 2.0,
        esc(ylabel)
    );
    for s in series {
        if s.line && s.points.len() > 1 {
            let pts: Vec<String> = s
                .points
                .iter()
                .map(|p| format!("{:.1},{:.1}", px(p.0), py(p.1)))
                .collect();
            let _ = writeln!(
                svg,
                r##"<polyline points="{}" fill="none" stroke="{}" stroke-width="1.5"/>"##,
                pts.join(" "),
                s.color
            );
        }
        for p in &s.points {
            let _ = writeln!(svg, "{}", marker(s.marker, px(p.0), py(p.1), s.color, &p.2));
        }
        if matches!(s.marker, Marker::Diamond) {
            for p in &s.points {
                let _ = writeln!(
                    svg,
                    r##"<text x="{:.1}" y="{:.1}" font-size="11" fill="{}">{}</text>"##,
                    px(p.0) + 6.0,
                    py(p.1) - 6.0,
                    s.color,
                    esc(&p.2)
                );
            }
        }
    }
}

fn marker(m: Marker, x: f64, y: f64, color: &str, title: &str) -> String {
    let t = format!("<title>{}</title>", esc(title));
    match m {
        Marker::Circle => {
            format!(r##"<circle cx="{x:.1}" cy="{y:.1}" r="3" fill="{color}">{t}</circle>"##)
        }
        Marker::Square => format!(
            r##"<rect x="{:.1}" y="{:.1}" width="6" height="6" fill="none" stroke="{color}" stroke-width="1.5">{t}</rect>"##,
            x - 3.0,
            y - 3.0
        ),
        Marker::Diamond => format!(
            r##"<path d="M{x:.1} {:.1} L{:.1} {y:.1} L{x:.1} {:.1} L{:.1} {y:.1} Z" fill="{color}">{t}</path>"##,
            y - 5.0,
            x + 5.0,
            y + 5.0,
            x - 5.0
        ),
        Marker::Triangle => format!(
            r##"<path d="M{x:.1} {:.1} L{:.1} {:.1} L{:.1} {:.1} Z" fill="{color}">{t}</path>"##,
            y - 4.0,
            x + 4.0,
            y + 3.0,
            x - 4.0,
            y + 3.0
        ),
    }
}

fn pow10(d: i32) -> String {
    match d {
        0 => "1".into(),
        1 => "10".into(),
        2 => "100".into(),
        -1 => "0.1".into(),
        -2 => "0.01".into(),
        _ => format!("1e{d}"),
    }
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
}

/// Two panels (relMSE, FLIP) against `axis`, with a shared legend.
fn draw(scene: &str, rows: &[Row], axis: Axis) -> String {
    let legend_h = 26.0;
    let mut svg = String::new();
    let _ = writeln!(
        svg,
        r##"<svg xmlns="http://www.w3.org/2000/svg" width="{}" height="{}" font-family="sans-serif" viewBox="0 0 {} {}"><rect width="100%" height="100%" fill="white"/>"##,
        2.0 * W,
        H + legend_h * 2.0,
        2.0 * W,
        H + legend_h * 2.0
    );
    let what = match axis {
        Axis::Time => "time",
        Axis::Memory => "memory",
    };
    let rel = series_for(rows, axis, "rel_mse");
    panel(
        &mut svg,
        0.0,
        &format!("{scene}: relMSE against {what}"),
        "relMSE vs reference",
        axis.label(),
        &rel,
    );
    panel(
        &mut svg,
        W,
        &format!("{scene}: mean FLIP against {what}"),
        "mean FLIP vs reference",
        axis.label(),
        &series_for(rows, axis, "flip"),
    );
    let mut x = 20.0;
    let mut y = H + 14.0;
    for s in &rel {
        if x > 2.0 * W - 260.0 {
            x = 20.0;
            y += legend_h;
        }
        let _ = writeln!(svg, "{}", marker(s.marker, x, y, s.color, &s.name));
        if s.line {
            let _ = writeln!(
                svg,
                r##"<line x1="{:.1}" y1="{y:.1}" x2="{:.1}" y2="{y:.1}" stroke="{}" stroke-width="1.5"/>"##,
                x - 10.0,
                x + 10.0,
                s.color
            );
        }
        let _ = writeln!(
            svg,
            r##"<text x="{:.1}" y="{:.1}" font-size="12">{}</text>"##,
            x + 16.0,
            y + 4.0,
            esc(&s.name)
        );
        x += 250.0;
    }
    svg.push_str("</svg>\n");
    svg
}

/// What the reading in docs/ACCURACY.md quotes for one scene.
struct Summary {
    scene: String,
    auto_time: f64,
    auto_rel: f64,
    auto_flip: f64,
    best_label: String,
    best_time: f64,
    best_rel: f64,
    /// auto relMSE / best grid relMSE within the auto bake's time (+10 %).
    ratio: f64,
    /// Path tracer seconds per view to reach the auto bake's relMSE.
    pt_time: f64,
    pt_extrapolated: bool,
    /// Views after which baking once is cheaper than path tracing each view.
    crossover_views: f64,
    radiosity: Option<(String, f64, f64)>,
}

fn summarize(scene: &str, rows: &[Row]) -> Summary {
    let vlf: Vec<&Row> = rows.iter().filter(|r| r.s("method") == "vlf").collect();
    let auto = vlf.iter().find(|r| r.s("preset") == "auto");
    let (auto_time, auto_rel, auto_flip) = auto.map_or((f64::NAN, f64::NAN, f64::NAN), |r| {
        (r.f("time_s"), r.f("rel_mse"), r.f("flip"))
    });
    // Same bake time: up to 10 % more than auto (timing noise), any parameters.
    let best = vlf
        .iter()
        .filter(|r| r.f("time_s") <= auto_time * 1.1)
        .min_by(|a, b| a.f("rel_mse").total_cmp(&b.f("rel_mse")));
    let (best_label, best_time, best_rel) = best.map_or((String::new(), f64::NAN, f64::NAN), |r| {
        (r.s("label").to_string(), r.f("time_s"), r.f("rel_mse"))
    });
    let mut pt: Vec<(f64, f64)> = rows
        .iter()
        .filter(|r| r.s("method") == "pathtrace")
        .map(|r| (r.f("time_s"), r.f("rel_mse")))
        .collect();
    pt.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (pt_time, pt_extrapolated) = time_to_error(&pt, auto_rel);
    let radiosity = rows
        .iter()
        .filter(|r| r.s("method").starts_with("radiosity"))
        .min_by(|a, b| a.f("rel_mse").total_cmp(&b.f("rel_mse")))
        .map(|r| (r.s("label").to_string(), r.f("time_s"), r.f("rel_mse")));
    Summary {
        scene: scene.into(),
        auto_time,
        auto_rel,
        auto_flip,
        best_label,
        best_time,
        best_rel,
        ratio: auto_rel / best_rel,
        pt_time,
        pt_extrapolated,
        crossover_views: auto_time / pt_time,
        radiosity,
    }
}

/// Time at which the error curve `pts` (time, error; increasing time) reaches `target`,
/// interpolated in log-log; beyond the last point, extrapolated with the Monte-Carlo rate
/// (error ∝ 1/time) from the last point.
fn time_to_error(pts: &[(f64, f64)], target: f64) -> (f64, bool) {
    if pts.is_empty() || !target.is_finite() {
        return (f64::NAN, false);
    }
    if pts[0].1 <= target {
        return (pts[0].0, false);
    }
    for w in pts.windows(2) {
        let ((t0, e0), (t1, e1)) = (w[0], w[1]);
        if e1 <= target {
            let s = (target.ln() - e0.ln()) / (e1.ln() - e0.ln());
            return ((t0.ln() + s * (t1.ln() - t0.ln())).exp(), false);
        }
    }
    let (t, e) = pts[pts.len() - 1];
    (t * e / target, true)
}

fn write_summary(out: &Path, summary: &[Summary]) -> Result<()> {
    let mut csv = String::from(
        "scene,auto_time_s,auto_rel_mse,auto_flip,best_label,best_time_s,best_rel_mse,\
         auto_over_best,pathtrace_time_s,pathtrace_extrapolated,crossover_views,\
         radiosity_best_label,radiosity_time_s,radiosity_rel_mse\n",
    );
    let mut md = String::from(
        "| scene | auto: bake s | relMSE | FLIP | best grid point ≤ 1.1× that time | its relMSE | auto / best | path tracer s to auto's relMSE | views to break even | best radiosity (s, relMSE) |\n\
         |---|---|---|---|---|---|---|---|---|---|\n",
    );
    for s in summary {
        let (rl, rt, re) = s
            .radiosity
            .clone()
            .unwrap_or((String::new(), f64::NAN, f64::NAN));
        let _ = writeln!(
            csv,
            "{},{:.3},{:.4e},{:.4},{},{:.3},{:.4e},{:.3},{:.3},{},{:.2},{},{:.3},{:.4e}",
            s.scene,
            s.auto_time,
            s.auto_rel,
            s.auto_flip,
            s.best_label,
            s.best_time,
            s.best_rel,
            s.ratio,
            s.pt_time,
            s.pt_extrapolated,
            s.crossover_views,
            rl,
            rt,
            re
        );
        let rad = if s.radiosity.is_some() {
            format!("{rl}: {rt:.2} s, {re:.2e}")
        } else {
            "n/a (not diffuse)".into()
        };
        let _ = writeln!(
            md,
            "| {} | {:.2} | {:.2e} | {:.3} | {} ({:.2} s) | {:.2e} | {:.2} | {:.2}{} | {:.1} | {} |",
            s.scene,
            s.auto_time,
            s.auto_rel,
            s.auto_flip,
            s.best_label,
            s.best_time,
            s.best_rel,
            s.ratio,
            s.pt_time,
            if s.pt_extrapolated {
                " (extrapolated)"
            } else {
                ""
            },
            s.crossover_views,
            rad
        );
    }
    let p: PathBuf = out.join("summary.csv");
    std::fs::write(&p, csv)?;
    eprintln!("wrote {}", p.display());
    let p = out.join("summary.md");
    std::fs::write(&p, &md)?;
    eprintln!("wrote {}\n{md}", p.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn time_to_error_interpolates_in_log_log_and_extrapolates_at_the_mc_rate() {
        let pts = [(1.0, 1e-1), (4.0, 2.5e-2)];
        // Halfway in log error between the two points is halfway in log time.
        let (t, ex) = time_to_error(&pts, 5e-2);
        assert!((t - 2.0).abs() < 1e-9 && !ex, "{t}");
        let (t, ex) = time_to_error(&pts, 2.5e-3);
        assert!((t - 40.0).abs() < 1e-9 && ex, "{t}");
        assert_eq!(time_to_error(&pts, 1.0), (1.0, false));
    }

    #[test]
    fn pareto_front_keeps_only_improving_points() {
        let pts = vec![
            (3.0, 1.0, "c".into()),
            (1.0, 5.0, "a".into()),
            (2.0, 6.0, "b".into()),
            (4.0, 0.5, "d".into()),
        ];
        let f: Vec<String> = pareto(&pts).into_iter().map(|p| p.2).collect();
        assert_eq!(f, ["a", "c", "d"]);
    }
}
