//! `bench` on tiny scenes: one row per structure with consistent counters, the same answers
//! from every correct structure, and a wrong structure caught by the same-answers check.

use hugrt::accel::{AnyAccel, PI, PIT, PrimitiveKind, Primitives, VT};
use hugrt::bench::{BenchRow, Candidate, Workload, bench_scene};
use hugrt::geometry::{Aabb, PreparedRay, Ray};
use hugrt::scene::{Scene, procedural::clustered_room};

const SPECS: &[&str] = &[
    "brute",
    "grid",
    "hug",
    "hug:filter=levels,min_cluster=1,loose=1e30",
];

fn workloads() -> [Workload; 4] {
    [
        Workload::Camera { side: 24 },
        Workload::Incoherent { rays: 3000 },
        Workload::Whitted {
            width: Some(40),
            height: Some(30),
            depth: 4,
            soft_shadows: None,
        },
        Workload::Whitted {
            width: Some(24),
            height: Some(16),
            depth: 2,
            soft_shadows: Some(0.01),
        },
    ]
}

fn run(scene: &Scene, candidates: &[Candidate], workload: Workload) -> Vec<BenchRow> {
    let mut seen = 0;
    let rows = bench_scene("tiny", scene, candidates, workload, 2, &mut |_| seen += 1).unwrap();
    assert_eq!(seen, candidates.len(), "one call per structure");
    rows
}

#[test]
fn rows_are_complete_and_counters_consistent() {
    let scene = clustered_room(2000, 7);
    let candidates: Vec<Candidate> = SPECS.iter().map(|s| Candidate::spec(&scene, s)).collect();
    for workload in workloads() {
        let rows = run(&scene, &candidates, workload);
        assert_eq!(rows.len(), SPECS.len());
        let whitted = matches!(workload, Workload::Whitted { .. });
        for (r, spec) in rows.iter().zip(SPECS) {
            let what = format!("{spec} on {workload:?}");
            assert_eq!(r.structure, *spec);
            assert_eq!(r.scene, "tiny");
            assert_eq!(r.primitives, scene.len());
            assert_eq!(r.differences, 0, "{what}: answers differ from brute force");
            assert_eq!(r.compared, if whitted { "pixels" } else { "rays" });
            assert!(r.rays > 0 && r.hits > 0 && r.hits <= r.rays, "{what}");
            assert!(r.build.min_ms <= r.build.median_ms && r.build.median_ms <= r.build.max_ms);
            assert!(r.trace.min_ms <= r.trace.median_ms && r.trace.median_ms <= r.trace.max_ms);
            assert!(r.trace.median_ms > 0.0 && r.mrays_per_s > 0.0, "{what}");
            // Counters: successes never exceed tests, per level and in total, and every hit
            // was a successful test.
            assert!(r.per_ray[PI] <= r.per_ray[PIT], "{what}");
            for l in &r.per_ray_levels {
                assert!(l[PI] <= l[PIT], "{what}: a level with more hits than tests");
            }
            let levels_pit: f64 = r.per_ray_levels.iter().map(|l| l[PIT]).sum();
            assert!((levels_pit - r.per_ray[PIT]).abs() <= 1e-9 * r.per_ray[PIT].max(1.0));
            assert!(
                r.per_ray[PI] * r.rays as f64 >= r.hits as f64 - 0.5,
                "{what}"
            );
            let s = &r.septet;
            assert!(s.n_c >= 1 && (0.0..=1.0).contains(&s.r_etnc), "{what}");
            assert!(
                s.n_adc >= 0.0 && s.n_aoifc >= 1.0 && s.r_fvwv > 0.0,
                "{what}"
            );
            assert!(s.n_rprt >= 1.0, "{what}: fewer tests than hits");
            assert_eq!(r.triplet.t_cb_ms, r.build.median_ms);
            assert_eq!(r.triplet.t_tr_ms, r.trace.median_ms);
            match r.triplet.t_tt_over_t_tr {
                Some(x) => assert!(whitted && (0.0..=1.0).contains(&x), "{what}"),
                None => assert!(!whitted, "{what}: no T_TT for a rendering"),
            }
            if *spec == "brute" {
                assert_eq!((s.n_c, s.n_tac), (1, 0));
            } else {
                assert!(s.n_tac > 0 && s.n_at > 0.0, "{what}: no cell traversed");
            }
        }
        // Every structure answers the same: the same hits and the same counts of rays.
        for r in &rows[1..] {
            assert_eq!((r.rays, r.hits), (rows[0].rays, rows[0].hits));
        }
        // The deep variant really is a hierarchy.
        assert!(rows[3].per_ray_levels.len() > 1);
    }
}

/// The scene with one primitive made unhittable in the structure's own copy: a structure
/// built over it misses that primitive, as a structure with a bug would.
struct DropOne<'a> {
    scene: &'a Scene,
    dropped: usize,
}

impl Primitives for DropOne<'_> {
    fn len(&self) -> usize {
        self.scene.len()
    }
    fn bounds(&self, i: usize) -> Aabb {
        Primitives::bounds(self.scene, i)
    }
    fn intersect(&self, i: usize, r: &PreparedRay, tmin: f32, tmax: f32) -> Option<f32> {
        (i != self.dropped)
            .then(|| self.scene.intersect(i, r, tmin, tmax))
            .flatten()
    }
    fn overlaps_box(&self, i: usize, b: &Aabb) -> bool {
        self.scene.overlaps_box(i, b)
    }
    fn kind(&self, i: usize) -> PrimitiveKind {
        match self.scene.kind(i) {
            // A degenerate triangle at the same place: never hit.
            PrimitiveKind::Triangle(v) if i == self.dropped => PrimitiveKind::Triangle([v[0]; 3]),
            k => k,
        }
    }
}

#[test]
fn a_structure_that_drops_a_primitive_is_caught() {
    let scene = clustered_room(2000, 8);
    // The primitive the camera looks at, so that every workload sees it go.
    let c = &scene.camera;
    let centre = Ray::new(c.from, c.at - c.from, 0.0, f32::INFINITY);
    let brute = AnyAccel::build(&scene, "brute").unwrap();
    let dropped = brute
        .closest_hit(&scene, &centre, &mut hugrt::accel::NoCounters)
        .expect("the camera sees the room")
        .prim as usize;
    assert!(matches!(scene.kind(dropped), PrimitiveKind::Triangle(_)));
    for spec in ["grid", "hug"] {
        let wrong = DropOne {
            scene: &scene,
            dropped,
        };
        let candidates = [
            Candidate::spec(&scene, spec),
            Candidate {
                label: format!("{spec} without primitive {dropped}"),
                build: Box::new(move || AnyAccel::build(&wrong, spec)),
                spec: spec.to_string(),
                packets: Default::default(),
            },
        ];
        for workload in [workloads()[0], workloads()[2]] {
            let rows = run(&scene, &candidates, workload);
            assert_eq!(rows[0].differences, 0);
            assert!(
                rows[1].differences > 0,
                "{spec} on {workload:?}: the dropped primitive went unnoticed"
            );
        }
    }
}

/// The counters of a render are one ray's walk whatever the packets, as the papers count:
/// a packet meets a cell once for its rays and may test more triangles, so counting the
/// timed render's walk would make the septet depend on `--packets`.
#[test]
fn whitted_counters_do_not_depend_on_packets() {
    use hugrt::accel::Packets;
    let scene = clustered_room(2000, 7);
    let with = |packets| Candidate {
        packets,
        ..Candidate::spec(&scene, "hug")
    };
    let candidates = [with(Packets::On), with(Packets::Off)];
    let workload = Workload::Whitted {
        width: Some(40),
        height: Some(30),
        depth: 2,
        soft_shadows: None,
    };
    let rows = run(&scene, &candidates, workload);
    assert_eq!(rows[1].differences, 0, "the same image");
    assert_eq!(
        format!("{:?}", rows[0].per_ray),
        format!("{:?}", rows[1].per_ray)
    );
    assert!(rows[0].per_ray[VT] > 0.0, "{:?}", rows[0].per_ray);
}
