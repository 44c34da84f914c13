//! Occlusion walked from the far end of a ray's segment (`HitSink::walked_back`): every
//! structure crosses the same cells or nodes as from the ray's start, answers the same, and
//! finds a blocker far from the origin sooner.

use hugrt::accel::{
    Accel, AdaptiveGrid, AnyAccel, AnyHit, Bvh, Grid, HitSink, Hug, KdTree, LevelCounts, Octree,
    PIT, Packets, Primitives, RayCounters, RecursiveGrid, Spec, VT,
};
use hugrt::geometry::{Ray, Vec3};
use hugrt::scene::Scene;

/// Tubes of four walls (`0.16` wide, four squares of `0.1` high each) standing around the
/// points `ORIGINS` lists on the plane `y = 0`, and a roof of squares of `0.1` at `y = 4` over
/// the part `x ≤ 4` of the scene: a ray from a tube's foot to a light high above leaves
/// through the tube's top, between walls whose cells and nodes it crosses.
fn tubes_and_roof() -> Scene {
    let mut tris = Vec::new();
    let mut square = |a: Vec3, u: Vec3, v: Vec3| {
        tris.push([a, a + u, a + u + v]);
        tris.push([a, a + u + v, a + v]);
    };
    for o in origins() {
        let h = 0.08;
        for level in 0..4 {
            let y = Vec3::Y * (0.1 * level as f32);
            let up = Vec3::Y * 0.1;
            let c = o + y;
            square(c + Vec3::new(-h, 0.0, -h), Vec3::X * 2.0 * h, up);
            square(c + Vec3::new(-h, 0.0, h), Vec3::X * 2.0 * h, up);
            square(c + Vec3::new(-h, 0.0, -h), Vec3::Z * 2.0 * h, up);
            square(c + Vec3::new(h, 0.0, -h), Vec3::Z * 2.0 * h, up);
        }
    }
    for i in 0..40 {
        for k in 0..80 {
            let a = Vec3::new(i as f32 * 0.1, 4.0, k as f32 * 0.1);
            square(a, Vec3::X * 0.1, Vec3::Z * 0.1);
        }
    }
    Scene::from_triangles(tris)
}

/// The rays' origins: the feet of the tubes, 40 × 40 points `0.2` apart.
fn origins() -> impl Iterator<Item = Vec3> {
    (0..40).flat_map(|i| {
        (0..40).map(move |k| Vec3::new(0.1 + i as f32 * 0.2, 0.0, 0.1 + k as f32 * 0.2))
    })
}

/// The answer and the counts of `ray`'s occlusion query in `accel`, walked from the far end
/// of its segment or not.
fn occlusion<A: Accel, P: Primitives>(
    accel: &A,
    prims: &P,
    ray: &Ray,
    far: bool,
) -> (bool, LevelCounts) {
    let mut sink = AnyHit::new(ray.tmax).walked_back(far);
    let mut counters = RayCounters::default();
    accel.query(prims, ray, &mut sink, &mut counters);
    (sink.hit().is_some(), counters.total())
}

fn check<A: Accel>(name: &str) {
    let scene = tubes_and_roof();
    let accel = A::build(&scene, &Spec::parse(name).unwrap()).unwrap();
    // Shadow rays from the tubes' feet to a light high above, outside the scene.
    let light = Vec3::new(4.3, 40.0, 4.1);
    let (mut blocked, mut lit) = (0, 0);
    // Tests on the blocked rays, from the start and from the far end.
    let mut tests = [0u64; 2];
    {
        for o in origins() {
            let ray = Ray::new(o, light - o, 1e-4, 1.0);
            let (hit_start, from_start) = occlusion(&accel, &scene, &ray, false);
            let (hit_end, from_end) = occlusion(&accel, &scene, &ray, true);
            assert_eq!(hit_start, hit_end, "{name}: {ray:?}");
            if hit_start {
                blocked += 1;
                // The roof is met before the tube's walls around the origin.
                assert!(
                    from_end[PIT] <= from_start[PIT],
                    "{name}: {ray:?}: {} tests from the far end, {} from the start",
                    from_end[PIT],
                    from_start[PIT]
                );
                tests[0] += from_start[PIT];
                tests[1] += from_end[PIT];
            } else {
                lit += 1;
                assert_eq!(
                    from_end[VT], from_start[VT],
                    "{name}: {ray:?}: the same cells"
                );
            }
        }
    }
    assert!(
        blocked > 600 && lit > 600,
        "{name}: {blocked} blocked, {lit} lit"
    );
    assert!(
        4 * tests[1] < 3 * tests[0],
        "{name}: {tests:?} tests from the start and from the far end"
    );
}

/// `$check::<A>(name)` for every structure but brute force (which has no order).
macro_rules! every_structure {
    ($check:ident) => {
        $check::<Hug>("hug");
        $check::<Grid>("grid");
        $check::<RecursiveGrid>("rgrid");
        $check::<Octree>("octree");
        $check::<AdaptiveGrid>("agrid");
        $check::<Bvh>("bvh");
        $check::<KdTree>("kdtree");
    };
}

#[test]
fn occlusion_from_the_far_end_crosses_the_same_cells_and_meets_the_blocker_first() {
    every_structure!(check);
}

/// The tests and cells of the shadow rays of [`tubes_and_roof`] through `accel`: asked one at
/// a time ([`Accel::any_hit`]), as a batch ([`Accel::any_hits`], every ray alone), and walked
/// from the start and from the far end by hand.
fn walks<A: Accel>(accel: &A, scene: &Scene) -> [(u64, u64); 4] {
    let light = Vec3::new(4.3, 40.0, 4.1);
    let rays: Vec<Ray> = origins()
        .map(|o| Ray::new(o, light - o, 1e-4, 1.0))
        .collect();
    let counts = |c: &LevelCounts| (c[PIT], c[VT]);
    let mut one = RayCounters::default();
    for ray in &rays {
        accel.any_hit(scene, ray, &mut one);
    }
    let mut batch = RayCounters::default();
    let mut out = vec![None; rays.len()];
    accel.any_hits(scene, &rays, Packets::Off, &mut out, &mut batch);
    let by_hand = |far: bool| {
        rays.iter()
            .map(|r| occlusion(accel, scene, r, far).1)
            .fold((0, 0), |(p, v), c| (p + c[PIT], v + c[VT]))
    };
    [
        counts(&one.total()),
        counts(&batch.total()),
        by_hand(false),
        by_hand(true),
    ]
}

fn check_setting<A: Accel>(name: &str) {
    let scene = tubes_and_roof();
    let ours = A::build(&scene, &Spec::parse(name).unwrap()).unwrap();
    let [one, batch, start, far] = walks(&ours, &scene);
    assert!(start != far, "{name}: the two walks differ here");
    assert_eq!((one, batch), (far, far), "{name}: walked from the far end");
    let papers = format!("{name}:occlusion=start");
    let theirs = A::build(&scene, &Spec::parse(&papers).unwrap()).unwrap();
    let [one, batch, start, _] = walks(&theirs, &scene);
    assert_eq!(
        (one, batch),
        (start, start),
        "{papers}: walked from the start"
    );
}

/// The `occlusion` key: hugrt's default walks occlusion queries from the far end of a segment
/// that leaves the scene, `start` (the papers' presets) from the origin, one ray at a time and
/// in batches, so that the presets' counters are counted as the papers counted theirs.
#[test]
fn the_occlusion_key_chooses_the_end_an_occlusion_query_starts_from() {
    every_structure!(check_setting);
    for paper in [
        "hug:preset=eg95",
        "hug:preset=scg97",
        "rgrid:preset=eg95",
        "octree:preset=eg95",
        "kdtree:preset=havran",
    ] {
        let keys = AnyAccel::resolve(paper).unwrap();
        assert!(
            keys.contains(&("occlusion", "start".to_string())),
            "{paper}: {keys:?}"
        );
    }
    let keys = AnyAccel::resolve("hug").unwrap();
    assert!(
        keys.contains(&("occlusion", "auto".to_string())),
        "{keys:?}"
    );
}
