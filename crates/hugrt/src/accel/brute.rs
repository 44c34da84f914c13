//! Brute force: every primitive is tested against every ray. The reference every other
//! structure is checked against, so it is kept as plain as possible.

use super::{
    Accel, CellCensus, Counters, HitSink, NoSettings, Primitives, SpecError, StructureStats,
};
use crate::geometry::{PreparedRay, Ray};

pub struct Brute {
    len: usize,
    reach: super::Reach,
    /// Volume of the primitives' bounding box: brute force's one cell.
    volume: f64,
}

impl Accel for Brute {
    const NAME: &'static str = "brute";
    type Settings = NoSettings;

    fn build_checked<P: Primitives>(prims: &P, _: &NoSettings) -> Result<Self, SpecError> {
        let reach = super::Reach::of(prims);
        let b = reach.bounds();
        let volume = if b.is_empty() { 0.0 } else { b.volume() as f64 };
        Ok(Brute {
            len: prims.len(),
            reach,
            volume,
        })
    }

    fn query<P: Primitives, C: Counters, S: HitSink>(
        &self,
        prims: &P,
        ray: &Ray,
        sink: &mut S,
        counters: &mut C,
    ) {
        let pr = PreparedRay::new(ray);
        for i in 0..self.len {
            counters.prim_test(0);
            if let Some(t) = prims.intersect(i, &pr, ray.tmin, sink.tmax()) {
                counters.prim_hit(0);
                if sink.offer(t, || i as u32) {
                    return;
                }
            }
        }
    }

    fn reach(&self) -> &crate::accel::Reach {
        &self.reach
    }

    /// Brute force tests every primitive in the order of the scene, whichever end it is
    /// asked to start from.
    fn occlusion(&self) -> crate::accel::Occlusion {
        crate::accel::Occlusion::Start
    }

    fn memory_bytes(&self) -> usize {
        std::mem::size_of::<Self>()
    }

    fn stats(&self) -> StructureStats {
        let mut s = StructureStats::default();
        s.push("primitives", self.len as f64);
        s.census = CellCensus {
            cells: 1,
            full_cells: (self.len > 0) as usize,
            object_refs: self.len,
            full_volume: self.volume,
        };
        s
    }
}
