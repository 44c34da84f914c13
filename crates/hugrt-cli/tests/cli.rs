//! The `hugrt` command end to end: outputs, formats, exit codes and error messages.

use std::path::Path;
use std::process::{Command, Output};

fn hugrt(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_hugrt"))
        .args(args)
        .output()
        .expect("hugrt runs")
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

fn fixture() -> String {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../hugrt/tests/fixtures/features.nff")
        .display()
        .to_string()
}

#[test]
fn render_writes_png_and_stats_json() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("f.png");
    let json = dir.path().join("f.json");
    let o = hugrt(&[
        "render",
        &fixture(),
        "-o",
        png.to_str().unwrap(),
        "--stats-json",
        json.to_str().unwrap(),
        "--quiet",
        "--width",
        "40",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let img = image::open(&png).unwrap();
    assert_eq!(
        (img.width(), img.height()),
        (40, 32),
        "height from the file, width overridden"
    );
    let j: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    for key in [
        "eye_rays",
        "eye_hits",
        "shadow_rays",
        "shadow_hits",
        "reflected_rays",
        "refracted_rays",
        "secondary_hits",
    ] {
        assert!(j[key].is_u64(), "{key} missing or not an integer in {j}");
    }
    assert_eq!(j["eye_rays"], 41 * 33);
    assert!(j["build_seconds"].is_f64() && j["render_seconds"].is_f64());
}

fn write_rays(path: &Path, rays: &[[f32; 8]]) {
    let bytes: Vec<u8> = rays
        .iter()
        .flatten()
        .flat_map(|x| x.to_le_bytes())
        .collect();
    std::fs::write(path, bytes).unwrap();
}

fn read_hits(path: &Path) -> Vec<(f32, u32)> {
    std::fs::read(path)
        .unwrap()
        .chunks_exact(8)
        .map(|c| {
            (
                f32::from_le_bytes(c[..4].try_into().unwrap()),
                u32::from_le_bytes(c[4..].try_into().unwrap()),
            )
        })
        .collect()
}

#[test]
fn trace_writes_the_embree_peer_hits_format() {
    let fx = fixture();
    let dir = tempfile::tempdir().unwrap();
    let rays = dir.path().join("r.rays");
    let inf = f32::INFINITY;
    write_rays(
        &rays,
        &[
            [0.0, -8.0, 3.0, 0.0, 0.0, 1.0, -0.3, inf], // into the scene
            [0.0, -8.0, 3.0, 0.0, 0.0, -1.0, 0.0, inf], // away from it
            [-1.5, 0.0, 5.0, 0.0, 0.0, 0.0, -1.0, inf], // straight down onto the red sphere
            [-1.5, 0.0, 5.0, 0.0, 0.0, 0.0, -1.0, 1.0], // stops short of it
        ],
    );
    let mut results = Vec::new();
    for (accel, any) in [("grid", false), ("brute", false), ("grid", true)] {
        let hits = dir.path().join(format!("{accel}{any}.hits"));
        let mut args = vec![
            "trace",
            &fx,
            "--rays",
            rays.to_str().unwrap(),
            "--hits",
            hits.to_str().unwrap(),
            "--accel",
            accel,
        ];
        if any {
            args.push("--any-hit");
        }
        let o = hugrt(&args);
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(stdout(&o).contains("Mrays/s"), "{}", stdout(&o));
        results.push(read_hits(&hits));
    }
    let closest = &results[0];
    assert_eq!(closest, &results[1], "grid and brute");
    assert!(closest[0].0.is_finite());
    assert_eq!(closest[1], (inf, u32::MAX));
    // The sphere of radius 0.8 centred at z = 1 is met at z = 1.8, t = 3.2.
    assert!((closest[2].0 - 3.2).abs() < 1e-5, "{:?}", closest[2]);
    assert_eq!(closest[3], (inf, u32::MAX));
    let any = &results[2];
    assert_eq!(any[2], (1.0, 0));
    assert_eq!(any[1], (inf, u32::MAX));
    // The full format: the same t and primitive, then u, v and the normal.
    let full = dir.path().join("full.hits");
    let o = hugrt(&[
        "trace",
        &fx,
        "--rays",
        rays.to_str().unwrap(),
        "--hits",
        full.to_str().unwrap(),
        "--hit-format",
        "full",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let bytes = std::fs::read(&full).unwrap();
    assert_eq!(bytes.len(), 28 * closest.len());
    let f = |r: &[u8], k: usize| f32::from_le_bytes(r[4 * k..4 * k + 4].try_into().unwrap());
    for (rec, want) in bytes.chunks_exact(28).zip(closest) {
        let prim = u32::from_le_bytes(rec[4..8].try_into().unwrap());
        assert_eq!((f(rec, 0), prim), *want);
        let n = (f(rec, 4), f(rec, 5), f(rec, 6));
        let len = (n.0 * n.0 + n.1 * n.1 + n.2 * n.2).sqrt();
        assert!(if want.0.is_finite() {
            (len - 1.0).abs() < 1e-4
        } else {
            len == 0.0
        });
    }
    // Straight down onto the red sphere: the normal points up.
    assert!((f(&bytes[56..84], 6) - 1.0).abs() < 1e-4);
    let o = hugrt(&[
        "trace",
        &fx,
        "--rays",
        rays.to_str().unwrap(),
        "--hits",
        full.to_str().unwrap(),
        "--hit-format",
        "full",
        "--any-hit",
    ]);
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    // Every hit: per ray a count, then (t, primitive) pairs in order of t; the first of them
    // is the closest hit.
    let all = dir.path().join("all.hits");
    let all_args = [
        "trace",
        &fx,
        "--rays",
        rays.to_str().unwrap(),
        "--hits",
        all.to_str().unwrap(),
        "--all-hits",
    ];
    let o = hugrt(&all_args);
    assert!(o.status.success(), "{}", stderr(&o));
    let bytes = std::fs::read(&all).unwrap();
    let word = |k: usize| <[u8; 4]>::try_from(&bytes[4 * k..4 * k + 4]).unwrap();
    let mut k = 0;
    for want in closest {
        let n = u32::from_le_bytes(word(k)) as usize;
        let pairs: Vec<(f32, u32)> = (0..n)
            .map(|i| {
                let w = k + 1 + 2 * i;
                (f32::from_le_bytes(word(w)), u32::from_le_bytes(word(w + 1)))
            })
            .collect();
        assert_eq!(pairs.first().copied().unwrap_or((inf, u32::MAX)), *want);
        assert!(pairs.windows(2).all(|p| p[0].0 <= p[1].0), "{pairs:?}");
        k += 1 + 2 * n;
    }
    assert_eq!(4 * k, bytes.len(), "nothing after the last ray's hits");
    let o = hugrt(&[&all_args[..], &["--any-hit"]].concat());
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    let o = hugrt(&[&all_args[..], &["--hit-format", "full"]].concat());
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
}

#[test]
fn errors_exit_nonzero_with_a_reason() {
    let fx = fixture();
    let fx = fx.as_str();
    let dir = tempfile::tempdir().unwrap();
    let bad = dir.path().join("bad.nff");
    std::fs::write(&bad, "s 0 0 0 1\ns 0 0 nan 1\n").unwrap();
    let bad = bad.to_str().unwrap();
    let short = dir.path().join("short.rays");
    std::fs::write(&short, [0u8; 33]).unwrap();
    let hits = dir.path().join("h.hits");
    let dir_name = dir.path().to_str().unwrap();
    let empty = dir.path().join("empty.obj");
    std::fs::write(&empty, "# nothing\n").unwrap();
    let empty = empty.to_str().unwrap();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["stats", bad], "bad.nff:2: sphere: coordinate is NaN"),
        (vec!["render", bad, "--quiet"], "bad.nff:2:"),
        (vec!["stats", "/nonexistent.ply"], "/nonexistent.ply"),
        (vec!["stats", fx, "--accel", "quadtree"], "brute, grid"),
        (vec!["stats", fx, "--accel", "grid:dens=3"], "density"),
        (vec!["stats", fx, "--accel", "grid:density=-1"], "density"),
        (
            vec![
                "trace",
                &fx,
                "--rays",
                short.to_str().unwrap(),
                "--hits",
                hits.to_str().unwrap(),
            ],
            "33",
        ),
        (vec!["render", "builtin:room:0", "--quiet"], "builtin:room"),
        (
            vec!["render", fx, "--threads", "10000", "--quiet"],
            "between 1 and 1024",
        ),
        (
            vec!["render", fx, "-o", dir_name, "--quiet"],
            "is a directory",
        ),
        (vec!["render", fx, "-o", "x.jpg", "--quiet"], "PNG"),
        (vec!["render", empty, "--quiet"], "no primitives"),
        (
            vec!["bench", "/nonexistent.ply", "--accel", "grid:dens=3"],
            "density",
        ),
        (
            vec!["stats", fx, "--accel", "grid:x"],
            "--accel grid:x: malformed spec: 'x'",
        ),
        (
            vec![
                "render",
                fx,
                "--eye",
                "1,1,1",
                "--look-at",
                "1,1,1",
                "--quiet",
            ],
            "same point",
        ),
        (
            vec!["render", fx, "--fov", "180", "--quiet"],
            "between 0 and 180",
        ),
    ];
    for (args, want) in cases {
        let o = hugrt(&args);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {}", stderr(&o));
        let e = stderr(&o);
        assert!(
            e.starts_with("hugrt: error: ") && e.contains(want),
            "{args:?}: {e}"
        );
        assert!(!e.contains("panicked"), "{args:?}: {e}");
    }
    // Values out of range are refused by the argument parser, before any work.
    for (args, want) in [
        (
            vec!["render", fx, "--width", "-5"],
            "-5 is not in 1..=65536",
        ),
        (vec!["render", fx, "--width", "0"], "0 is not in 1..=65536"),
        (
            vec!["render", fx, "--depth", "5000"],
            "5000 is not in 0..=64",
        ),
        (vec!["bench", fx, "--repeat", "0"], "0 is not in 1..=1000"),
        (vec!["bench", fx, "--ray-count", "0"], "0 is not in"),
        (vec!["render", fx, "--eye", "1,nan,2"], "finite"),
        (vec!["render", fx, "--look-at", "1,2"], "not X,Y,Z"),
    ] {
        let o = hugrt(&args);
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
        assert!(stderr(&o).contains(want), "{args:?}: {}", stderr(&o));
    }
    // A view of one's own: another image than the scene's camera gives.
    let (own, scenes) = (dir.path().join("own.png"), dir.path().join("scene.png"));
    for (args, out) in [
        (
            vec!["--eye", "-3,-4.5,2", "--look-at", "0,0,0.5", "--fov", "60"],
            &own,
        ),
        (vec![], &scenes),
    ] {
        let mut a = vec!["render", fx, "--quiet", "-o", out.to_str().unwrap()];
        a.extend(args);
        let o = hugrt(&a);
        assert!(o.status.success(), "{}", stderr(&o));
    }
    assert_ne!(
        std::fs::read(&own).unwrap(),
        std::fs::read(&scenes).unwrap()
    );
    // An empty scene renders when asked to.
    let out = dir.path().join("e.png");
    let o = hugrt(&[
        "render",
        empty,
        "--allow-empty",
        "--quiet",
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn stats_json_reports_scene_and_structure() {
    let o = hugrt(&["stats", &fixture(), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(j["scene_stats"]["objects"], 13);
    assert!(j["structure"]["bytes_per_primitive"].as_f64().unwrap() > 0.0);
    // The default structure is the HUG, with SCG97 §3's statistics per level.
    assert_eq!(j["accel"], "hug");
    assert!(j["structure"]["references_per_object"].as_f64().unwrap() >= 1.0);
    assert_eq!(j["levels"][0]["pct_vol"], 100.0);
    let total: f64 = (0..j["levels"].as_array().unwrap().len())
        .map(|l| j["levels"][l]["pct_obj"].as_f64().unwrap())
        .sum();
    assert!((total - 100.0).abs() < 1e-9, "{total}");
    let o = hugrt(&["stats", "builtin:kitchen:1"]);
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(
        text.contains("per filter level")
            && text.contains("per nesting depth")
            && text.contains("σo'_v"),
        "{text}"
    );
}

#[test]
fn gen_writes_nff_and_ply_that_load_back() {
    let dir = tempfile::tempdir().unwrap();
    for ext in ["nff", "ply"] {
        let out = dir.path().join(format!("flake.{ext}"));
        let o = hugrt(&[
            "gen",
            "sphereflake",
            "--size",
            "2",
            "-o",
            out.to_str().unwrap(),
        ]);
        assert!(o.status.success(), "{}", stderr(&o));
        let s = hugrt::scene::Scene::load(&out).unwrap();
        assert!(!s.is_empty());
    }
    let bad = dir.path().join("flake.obj");
    let o = hugrt(&["gen", "sphereflake", "-o", bad.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains(".nff or .ply"), "{}", stderr(&o));
    assert!(!bad.exists(), "nothing is written for a bad extension");
    let o = hugrt(&[
        "render",
        "builtin:kitchen:1",
        "--width",
        "24",
        "--height",
        "16",
        "--quiet",
        "-o",
        dir.path().join("k.png").to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let o = hugrt(&["stats", "builtin:castle"]);
    assert!(
        stderr(&o).contains("there are: room, kitchen"),
        "{}",
        stderr(&o)
    );
}

/// `bench` on a tiny scene: the table's header and one row per structure on stdout, the same
/// rows in JSON and CSV, every structure agreeing, and soft shadows accepted.
#[test]
fn bench_prints_a_row_per_structure_and_writes_json_and_csv() {
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("b.json");
    let csv = dir.path().join("b.csv");
    let specs = ["grid", "hug", "hug:filter=levels,world=2n"];
    for rays in ["whitted", "camera", "incoherent"] {
        let mut args = vec![
            "bench",
            "builtin:room:2000",
            "--rays",
            rays,
            "--repeat",
            "2",
            "--camera",
            "16",
            "--ray-count",
            "500",
            "--width",
            "24",
            "--height",
            "16",
            "--soft-shadows",
            "--threads",
            "2",
            "--quiet",
            "--json",
            json.to_str().unwrap(),
            "--csv",
            csv.to_str().unwrap(),
        ];
        for s in specs {
            args.extend(["--accel", s]);
        }
        let o = hugrt(&args);
        assert!(o.status.success(), "{rays}: {}", stderr(&o));
        let out = String::from_utf8_lossy(&o.stdout);
        let header = out.lines().next().unwrap();
        for column in [
            "build ms",
            "Mrays/s",
            "N_C",
            "R_ETNC",
            "N_ADC",
            "N_AOIFC",
            "R_FVWV",
            "N_RPRT",
            "N_AT",
            "T_TT/T_TR",
            "differ",
        ] {
            assert!(
                header.contains(column),
                "{rays}: no column {column} in {header}"
            );
        }
        for s in specs {
            let row = out
                .lines()
                .find(|l| {
                    l.starts_with("| builtin:room:2000 | ") && l.contains(&format!(" | {s} | "))
                })
                .unwrap_or_else(|| panic!("{rays}: no row for {s} in\n{out}"));
            assert!(
                row.ends_with(if rays == "whitted" {
                    "| 0 pixels |"
                } else {
                    "| 0 rays |"
                }),
                "{row}"
            );
        }
        let rows: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        let rows = rows.as_array().unwrap();
        assert_eq!(rows.len(), specs.len());
        for (r, s) in rows.iter().zip(specs) {
            assert_eq!(r["structure"], s);
            assert!(r["septet"]["n_c"].as_u64().unwrap() > 0);
            assert!(
                r["per_ray_levels"]
                    .as_array()
                    .is_some_and(|l| !l.is_empty())
            );
        }
        let text = std::fs::read_to_string(&csv).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 1 + specs.len(), "{text}");
        assert!(lines[0].starts_with("scene,primitives,structure,"));
        // The spec with a comma is quoted, not split.
        assert!(
            lines[3].contains("\"hug:filter=levels,world=2n\""),
            "{}",
            lines[3]
        );
    }
}

#[test]
fn bench_rejects_a_bad_light_radius_and_unknown_structure() {
    let o = hugrt(&["bench", "builtin:room:500", "--soft-shadows=-1", "--quiet"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("light radius"), "{}", stderr(&o));
    let o = hugrt(&["bench", "builtin:room:500", "--accel", "octopus", "--quiet"]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("octopus"), "{}", stderr(&o));
}

/// A reader that goes away (`hugrt stats ... | head`) ends the command quietly: exit 0, no
/// panic message. The pipe is closed before the scene is even generated.
#[test]
fn closed_stdout_ends_quietly() {
    let mut child = Command::new(env!("CARGO_BIN_EXE_hugrt"))
        .args(["stats", "builtin:kitchen"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("hugrt runs");
    drop(child.stdout.take());
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{:?}: {}", o.status, stderr(&o));
    assert!(stderr(&o).is_empty(), "{}", stderr(&o));
}

/// `bench` checks the image it will render as `render` does, before any work.
#[test]
fn bench_rejects_a_bad_image_side() {
    for args in [["--width", "0"], ["--height", "70000"], ["--camera", "0"]] {
        let mut a = vec!["bench", "builtin:room:500", "--quiet"];
        a.extend(args);
        let o = hugrt(&a);
        assert!(!o.status.success(), "{args:?}");
        assert!(
            stderr(&o).contains("is not in 1..=65536"),
            "{args:?}: {}",
            stderr(&o)
        );
    }
}

#[test]
fn reproduce_writes_a_report_and_its_data() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let o = hugrt(&["reproduce", "scg97-scenes", "--quick", "-o", out]);
    assert!(o.status.success(), "{}", stderr(&o));
    let t = dir.path().join("scg97-scenes");
    let report = std::fs::read_to_string(t.join("report.md")).unwrap();
    // The published row beside the measured one, and a verdict.
    assert!(
        report.contains("| Kitchen | 20947 | 9.0e-4 | 6.5e-4 | 99.29 | `builtin:kitchen:1` |"),
        "{report}"
    );
    assert!(report.contains("Verdict:"), "{report}");
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(t.join("data.json")).unwrap()).unwrap();
    assert_eq!(j["published"].as_array().unwrap().len(), 5);
    assert_eq!(j["measured"].as_array().unwrap().len(), 4);
    let csv = std::fs::read_to_string(t.join("histogram.csv")).unwrap();
    assert_eq!(csv.lines().count(), 1 + 4 * 20);
    let scenes = std::fs::read_to_string(t.join("scenes.csv")).unwrap();
    assert_eq!(scenes.lines().count(), 1 + 4);
    let o = hugrt(&["reproduce", "eg96-kitchens", "-o", out]);
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("targets: eg95-kitchens, scg97-scenes"),
        "{}",
        stderr(&o)
    );
}

#[test]
fn reproduce_rtnews_runs_on_the_spd_scenes_or_says_they_are_missing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let nowhere = dir.path().join("no-scenes");
    let o = hugrt(&[
        "reproduce",
        "rtnews-spd",
        "--quick",
        "-o",
        out,
        "--spd-dir",
        nowhere.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let report = std::fs::read_to_string(dir.path().join("rtnews-spd/report.md")).unwrap();
    assert!(
        report.contains("Skipped") && report.contains("balls.nff.gz"),
        "{report}"
    );
    let spd = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes/spd");
    if !spd.is_dir() {
        eprintln!(
            "skipped: {} not found (the shared scenes are not beside this clone)",
            spd.display()
        );
        return;
    }
    let o = hugrt(&[
        "reproduce",
        "rtnews-spd",
        "--quick",
        "-o",
        out,
        "--spd-dir",
        spd.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("rtnews-spd/data.json")).unwrap(),
    )
    .unwrap();
    // Eight scenes, five structures each, each uniform grid at D = 1 its own reference.
    let rows = j["rows"].as_array().unwrap();
    assert_eq!(rows.len(), 40);
    for r in rows.iter().step_by(5) {
        assert_eq!(r["measured_over_d1"], 1.0, "{r}");
        assert_eq!(r["spec"], "grid:density=1");
    }
}

#[test]
fn structures_lists_every_key_with_its_default() {
    let o = hugrt(&["structures"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let out = stdout(&o);
    for name in hugrt::accel::STRUCTURES {
        assert!(out.contains(name), "{name}: {out}");
    }
    assert!(out.contains("leaf         1..16  (default 8)"), "{out}");
    let o = hugrt(&["structures", "hug", "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let keys = j["hug"].as_array().unwrap();
    assert!(
        keys.iter()
            .any(|k| k["name"] == "crowd" && k["default"] == "64")
    );
    let o = hugrt(&["structures", "quadtree"]);
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("brute, grid"), "{}", stderr(&o));
}

#[test]
fn reproduce_havran_layouts_measures_the_cache_under_cachegrind() {
    let valgrind = std::process::Command::new("valgrind")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success());
    if !valgrind {
        eprintln!("skipped: valgrind is not installed (Debian's package `valgrind`)");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let o = hugrt(&["reproduce", "havran-layouts", "--quick", "-o", out]);
    assert!(o.status.success(), "{}", stderr(&o));
    let t = dir.path().join("havran-layouts");
    let csv = std::fs::read_to_string(t.join("layouts.csv")).unwrap();
    let report = std::fs::read_to_string(t.join("report.md")).unwrap();
    assert!(report.contains("Cachegrind ran"), "{report}");
    let mut r = csv::Reader::from_reader(csv.as_bytes());
    let h = r.headers().unwrap().clone();
    let at = |name: &str| h.iter().position(|x| x == name).unwrap();
    let (refs, misses, hits) = (
        at("data_refs_per_ray"),
        at("d1_misses_per_ray"),
        at("d1_hit_percent"),
    );
    for rec in r.records() {
        let rec = rec.unwrap();
        let n = |k: usize| rec[k].parse::<f64>().unwrap();
        // Per ray of the difference: references and misses, and the share they make.
        assert!(n(refs) > 0.0 && n(misses) >= 0.0, "{rec:?}");
        let share = 100.0 * (1.0 - n(misses) / n(refs));
        assert!((share - n(hits)).abs() < 1e-6, "{rec:?}");
    }
}

/// Chromium where the machine has it (Debian's `chromium`; `.ci/run` installs it).
fn chromium() -> Option<&'static str> {
    ["chromium", "chromium-browser"].into_iter().find(|c| {
        std::process::Command::new(c)
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success())
    })
}

/// Opens `page` in headless Chromium with a script that records every failed load, script
/// error, console error and image without pixels, and returns what it recorded ("ok" when
/// nothing).
fn check_in_chromium(browser: &str, page: &Path) -> String {
    let html = std::fs::read_to_string(page).unwrap();
    let probe = "<script>var problems=[];\
        window.addEventListener('error',function(e){var t=e.target;\
        problems.push(t&&t.src?'missing '+t.src:'error '+e.message);},true);\
        var ce=console.error;console.error=function(){problems.push('console '+\
        Array.prototype.join.call(arguments,' '));ce.apply(console,arguments);};\
        window.addEventListener('load',function(){for(var i of document.images){\
        if(!i.complete||i.naturalWidth===0)problems.push('broken '+i.src);}\
        document.body.setAttribute('data-check',problems.length?problems.join('|'):'ok');});\
        </script>";
    let probed = page.with_file_name("probed.html");
    std::fs::write(
        &probed,
        html.replacen("<head>", &format!("<head>\n{probe}"), 1),
    )
    .unwrap();
    let profile = tempfile::tempdir().unwrap();
    let o = std::process::Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--allow-file-access-from-files",
            "--virtual-time-budget=10000",
        ])
        .arg(format!("--user-data-dir={}", profile.path().display()))
        .arg("--dump-dom")
        .arg(format!("file://{}", probed.display()))
        .output()
        .unwrap();
    let dom = String::from_utf8_lossy(&o.stdout);
    dom.split("data-check=\"")
        .nth(1)
        .and_then(|s| s.split('"').next())
        .map_or_else(
            || format!("no verdict from the page: {dom}"),
            str::to_string,
        )
}

#[test]
fn reproduce_index_renders_in_chromium_with_every_image_and_no_error() {
    let Some(browser) = chromium() else {
        eprintln!("skipped: Chromium is not installed (Debian's package `chromium`)");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().to_str().unwrap();
    let o = hugrt(&[
        "reproduce",
        "eg95-kitchens",
        "scg97-levels",
        "scg97-improved",
        "--quick",
        "-o",
        out,
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let index = dir.path().join("index.html");
    assert!(std::fs::read_to_string(&index).unwrap().contains("<img"));
    assert_eq!(check_in_chromium(browser, &index), "ok");
    // The check can fail: a plot taken away is reported missing.
    std::fs::remove_file(dir.path().join("scg97-improved/time-memory.svg")).unwrap();
    let found = check_in_chromium(browser, &index);
    assert!(
        found.contains("time-memory.svg"),
        "a missing image went unnoticed: {found}"
    );
}

/// An instanced building from `gen --instanced`: rendered, traced (hits by model, primitive
/// and instance) and measured with its instances kept.
#[test]
fn instanced_scenes_render_trace_and_report_their_instances() {
    let dir = tempfile::tempdir().unwrap();
    let nff = dir.path().join("b.nff");
    let o = hugrt(&["gen", "town", "-o", nff.to_str().unwrap()]);
    assert!(!o.status.success());
    assert!(stderr(&o).contains("--instanced"), "{}", stderr(&o));
    let o = hugrt(&[
        "gen",
        "building",
        "--instanced",
        "--size",
        "3",
        "-o",
        nff.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stdout(&o).contains("instanced"), "{}", stdout(&o));
    let png = dir.path().join("b.png");
    let json = dir.path().join("b.json");
    let o = hugrt(&[
        "render",
        nff.to_str().unwrap(),
        "-o",
        png.to_str().unwrap(),
        "--width",
        "48",
        "--height",
        "48",
        "--quiet",
        "--stats-json",
        json.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    assert_eq!(j["instances"], 3);
    assert!(j["eye_hits"].as_u64().unwrap() > 100, "{j}");
    // A ray down the middle of the first kitchen hits its floor from above.
    let rays = dir.path().join("r.bin");
    let hits = dir.path().join("h.bin");
    write_rays(
        &rays,
        &[
            [3.0, 2.5, 2.5, 0.0, 0.0, -1.0, 0.0, f32::INFINITY],
            [3.0, -5.0, 2.5, 0.0, 0.0, -1.0, 0.0, f32::INFINITY],
        ],
    );
    let o = hugrt(&[
        "trace",
        nff.to_str().unwrap(),
        "--rays",
        rays.to_str().unwrap(),
        "--hits",
        hits.to_str().unwrap(),
        "--hit-format",
        "instanced",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let bytes = std::fs::read(&hits).unwrap();
    assert_eq!(bytes.len(), 48);
    let u32_at = |k: usize| u32::from_le_bytes(bytes[k..k + 4].try_into().unwrap());
    let t = f32::from_le_bytes(bytes[0..4].try_into().unwrap());
    assert!(t > 0.0 && t <= 2.5, "t {t}");
    assert_eq!(
        (u32_at(4), u32_at(12)),
        (0, 0),
        "model 0 (the kitchen), instance 0"
    );
    assert_eq!(
        f32::from_le_bytes(bytes[24..28].try_into().unwrap()),
        f32::INFINITY
    );
    let o = hugrt(&["stats", nff.to_str().unwrap(), "--json"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let j: serde_json::Value = serde_json::from_str(&stdout(&o)).unwrap();
    assert_eq!(j["structure"]["instances"], 3.0);
    assert_eq!(j["structure"]["models"], 2.0);
}
