//! Replays what the fuzz targets in `fuzz/` have kept: the hand-written seeds, the corpus
//! libFuzzer grew (minimised) and every input that once crashed a target, through the same
//! functions the targets call ([`hugrt::fuzzing`]). This runs on the stable toolchain; the
//! fuzzing itself is `fuzz/README.md`'s.

use std::path::{Path, PathBuf};

/// The fuzz targets, each with the loader its inputs go to.
const TARGETS: &[&str] = &["nff", "ply", "obj", "stl", "gltf", "rays"];

fn inputs(target: &str) -> Vec<PathBuf> {
    let fuzz = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fuzz");
    let mut files = Vec::new();
    for kind in ["seeds", "corpus", "regressions"] {
        let Ok(dir) = std::fs::read_dir(fuzz.join(kind).join(target)) else {
            continue;
        };
        files.extend(dir.map(|e| e.unwrap().path()).filter(|p| p.is_file()));
    }
    files.sort();
    files
}

fn replay(target: &str) -> usize {
    let files = inputs(target);
    for f in &files {
        // A file libFuzzer replaced while this ran (a campaign beside the tests) is skipped.
        let Ok(data) = std::fs::read(f) else {
            continue;
        };
        let run = std::panic::catch_unwind(|| match target {
            "rays" => hugrt::fuzzing::rays_file(&data),
            "gltf" if data.starts_with(b"glTF") => hugrt::fuzzing::scene_file("fuzz.glb", &data),
            ext => hugrt::fuzzing::scene_file(&format!("fuzz.{ext}"), &data),
        });
        assert!(run.is_ok(), "{} fails again", f.display());
    }
    files.len()
}

#[test]
fn every_target_has_seeds_in_the_repo() {
    for t in TARGETS {
        assert!(replay(t) > 0, "fuzz/seeds/{t} is empty");
    }
}
