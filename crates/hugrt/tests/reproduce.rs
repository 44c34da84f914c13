//! The reproductions' quick runs: each writes its report, data and plots, with numbers that
//! agree with each other (rows in the CSV and the JSON, shares that sum to 100, ratios of
//! the values beside them) and a verdict computed for every claim it tests.

use std::path::{Path, PathBuf};

fn run(target: &str, spd_dir: &Path) -> (PathBuf, PathBuf) {
    let dir = std::env::temp_dir().join(format!("hugrt-{target}-{}", std::process::id()));
    let options = hugrt::reproduce::Options {
        quick: true,
        spd_dir: spd_dir.to_path_buf(),
        ..Default::default()
    };
    let out = hugrt::reproduce::run(target, &options, &dir).unwrap();
    (dir, out)
}

fn read(dir: &Path, file: &str) -> String {
    std::fs::read_to_string(dir.join(file)).unwrap_or_else(|e| panic!("{file}: {e}"))
}

fn csv_rows(text: &str) -> Vec<std::collections::HashMap<String, String>> {
    let mut r = csv::Reader::from_reader(text.as_bytes());
    let headers = r.headers().unwrap().clone();
    r.records()
        .map(|rec| {
            let rec = rec.unwrap();
            headers
                .iter()
                .zip(rec.iter())
                .map(|(h, v)| (h.to_string(), v.to_string()))
                .collect()
        })
        .collect()
}

/// The SPD scenes beside this clone, if they are there.
fn spd() -> Option<PathBuf> {
    let spd = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes/spd");
    if spd.is_dir() {
        Some(spd)
    } else {
        eprintln!(
            "skipped the SPD part: {} not found (the shared scenes are not beside this clone)",
            spd.display()
        );
        None
    }
}

fn verdict_lines(report: &str) -> Vec<&str> {
    report
        .split("## Verdict")
        .nth(1)
        .unwrap_or_else(|| panic!("no verdict: {report}"))
        .lines()
        .filter(|l| l.starts_with("- "))
        .collect()
}

fn check_havran_splits(out: &Path, scenes: usize) {
    let report = read(out, "report.md");
    let planes = csv_rows(&read(out, "planes.csv"));
    let properties = csv_rows(&read(out, "properties.csv"));
    let json: serde_json::Value = serde_json::from_str(&read(out, "data.json")).unwrap();
    assert_eq!(planes.len(), scenes, "{report}");
    assert_eq!(properties.len(), 10 * scenes);
    assert_eq!(json["planes"].as_array().unwrap().len(), planes.len());
    assert_eq!(
        json["properties"].as_array().unwrap().len(),
        properties.len()
    );
    let number = |r: &std::collections::HashMap<String, String>, k: &str| -> f64 {
        r[k].parse().unwrap_or_else(|_| panic!("{k} = {}", r[k]))
    };
    for p in &planes {
        let share = number(p, "outside_percent");
        assert!((0.0..=100.0).contains(&share) && number(p, "planes") > 0.0);
    }
    for p in &properties {
        let r = number(p, "published_2") / number(p, "published_1");
        assert!((number(p, "published_ratio") - r).abs() < 1e-9);
        if !p["measured_ratio"].is_empty() {
            let m = number(p, "measured_2") / number(p, "measured_1");
            assert!((number(p, "measured_ratio") - m).abs() < 1e-9 * m.abs().max(1.0));
        }
    }
    // Table 4's claim and three of Tables 5-6's, each judged.
    let judged = verdict_lines(&report)
        .iter()
        .filter(|l| ["holds", "does not hold"].iter().any(|w| l.contains(w)))
        .count();
    assert_eq!(judged, 4, "{report}");
    // A plotted point per scene, published and today.
    for plot in ["table4-outside-median.svg", "tables5-6-render-ratio.svg"] {
        assert_eq!(
            read(out, plot).matches("<circle").count(),
            2 * scenes,
            "{plot}"
        );
    }
    // Havran's fluid scenes are not available: said, not hidden.
    assert!(report.contains("fluid: not available"), "{report}");
}

#[test]
fn havran_splits_quick_writes_consistent_data() {
    let (dir, out) = run("havran-splits", Path::new("no-such-folder"));
    // Only the generated stand-in for Havran's room without the SPD scenes.
    check_havran_splits(&out, 1);
    std::fs::remove_dir_all(&dir).unwrap();
    if let Some(spd) = spd() {
        let (dir, out) = run("havran-splits", &spd);
        check_havran_splits(&out, 4);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}

#[test]
fn scg97_levels_quick_writes_consistent_data_and_plots() {
    let (dir, out) = run("scg97-levels", Path::new("no-such-folder"));
    let report = read(&out, "report.md");
    let levels = csv_rows(&read(&out, "levels.csv"));
    let rendering = csv_rows(&read(&out, "rendering.csv"));
    let json: serde_json::Value = serde_json::from_str(&read(&out, "data.json")).unwrap();
    assert_eq!(json["levels"].as_array().unwrap().len(), levels.len());
    assert_eq!(json["rendering"].as_array().unwrap().len(), rendering.len());
    let number = |r: &std::collections::HashMap<String, String>, k: &str| -> f64 {
        r[k].parse().unwrap_or_else(|_| panic!("{k} = {}", r[k]))
    };
    // Shares of a structure's levels sum to 100: objects, grids, cells, references.
    for s in ["g28", "hug", "r50"] {
        let of: Vec<_> = levels.iter().filter(|r| r["structure"] == s).collect();
        assert!(!of.is_empty(), "{s}");
        for k in ["pct_obj", "pct_grids", "pct_voxels", "pct_ptrs"] {
            let sum: f64 = of.iter().map(|r| number(r, k)).sum();
            assert!((sum - 100.0).abs() < 1e-6, "{s} {k} sums to {sum}");
        }
        for view in ["fig5", "fig21"] {
            let of: Vec<_> = rendering
                .iter()
                .filter(|r| r["structure"] == s && r["view"] == view)
                .collect();
            for k in ["pct_pit", "pct_pi", "pct_bbi", "pct_vt"] {
                let sum: f64 = of.iter().map(|r| number(r, k)).sum();
                assert!((sum - 100.0).abs() < 1e-6, "{s} {view} {k} sums to {sum}");
            }
        }
    }
    // A plotted point per level of the HUG and r50, today's and the paper's.
    for view in ["fig5", "fig21"] {
        let today = rendering
            .iter()
            .filter(|r| r["view"] == view && r["structure"] != "g28")
            .count();
        // SCG97 gives 3 HUG levels and 4 r50 levels from each viewpoint.
        let published = 7;
        let svg = read(&out, &format!("pit-levels-{view}.svg"));
        assert_eq!(svg.matches("<circle").count(), today + published, "{view}");
        // The PNG beside it, where the machine has a font to draw its text with.
        let png = out.join(format!("pit-levels-{view}.png"));
        let font = Path::new("/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf").is_file();
        if font {
            let image = image::open(&png).unwrap();
            assert_eq!((image.width(), image.height()), (720, 480));
        } else {
            eprintln!("no DejaVu Sans here: the PNG plots may be left out");
        }
    }
    let judged = verdict_lines(&report)
        .iter()
        .filter(|l| {
            ["holds", "is a tie here", "does not hold"]
                .iter()
                .any(|w| l.contains(w))
        })
        .count();
    assert_eq!(judged, 9, "{report}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn scg97_improved_quick_judges_both_claims_from_its_rows() {
    let (dir, out) = run("scg97-improved", Path::new("no-such-folder"));
    let report = read(&out, "report.md");
    let rows = csv_rows(&read(&out, "rows.csv"));
    // Three world grids and three MAXPs on the quick run's kitchen.
    assert_eq!(rows.len(), 6, "{report}");
    assert_eq!(
        read(&out, "time-memory.svg").matches("<circle").count(),
        rows.len()
    );
    for r in &rows {
        assert!(r["memory_mb"].parse::<f64>().unwrap() > 0.0);
        assert!(report.contains(&format!("`{}`", r["spec"].replace(';', ","))));
    }
    let judged = verdict_lines(&report)
        .iter()
        .filter(|l| {
            ["holds", "is a tie here", "does not hold", "not judged"]
                .iter()
                .any(|w| l.contains(w))
        })
        .count();
    assert_eq!(judged, 2, "{report}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn havran_layouts_quick_times_every_layout_and_says_what_it_could_not_measure() {
    // The library gives no hugrt binary to run under cachegrind: the report says so.
    let (dir, out) = run("havran-layouts", Path::new("no-such-folder"));
    let report = read(&out, "report.md");
    let rows = csv_rows(&read(&out, "layouts.csv"));
    assert_eq!(rows.len(), 5, "{report}");
    let dfs = rows.iter().find(|r| r["layout"] == "depth-first").unwrap();
    assert_eq!(dfs["time_over_dfs"].parse::<f64>().unwrap(), 1.0);
    assert!(rows.iter().all(|r| r["d1_misses_per_ray"].is_empty()));
    assert!(report.contains("Cachegrind was not run"), "{report}");
    // Havran's four representations and today's five layouts; no misses plot without them.
    assert_eq!(read(&out, "table7-time.svg").matches("<circle").count(), 9);
    assert!(!out.join("table7-misses.svg").exists());
    let lines = verdict_lines(&report);
    assert_eq!(lines.len(), 5, "{report}");
    assert!(lines[4].contains("not judged"), "{report}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn scg97_scenes_plots_a_point_per_histogram_row() {
    let (dir, out) = run("scg97-scenes", Path::new("no-such-folder"));
    let rows = csv_rows(&read(&out, "histogram.csv"));
    for plot in ["lengths-histogram.svg", "lengths-cumulative.svg"] {
        assert_eq!(
            read(&out, plot).matches("<circle").count(),
            rows.len(),
            "{plot}"
        );
    }
    // Each scene's cumulative share ends at its share below a fifth of the longest.
    let scenes = csv_rows(&read(&out, "scenes.csv"));
    for s in &scenes {
        let last = rows.iter().rfind(|r| r["scene"] == s["scene"]).unwrap();
        let (a, b): (f64, f64) = (
            last["cumulative_percent"].parse().unwrap(),
            s["percent_below_0_2"].parse().unwrap(),
        );
        assert!((a - b).abs() < 1e-6, "{}: {a} against {b}", s["scene"]);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
