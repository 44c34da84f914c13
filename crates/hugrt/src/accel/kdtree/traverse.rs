//! The query: the near/far descent with an explicit stack, over any of the layouts.

use super::layout::{NodeStore, Visit};
use super::{KdTree, MAX_DEPTH};
use crate::accel::{Counters, HitSink, Mailbox, Primitives};
use crate::geometry::{PreparedRay, Ray};

impl KdTree {
    /// The near/far descent (module documentation) over one of the layouts.
    #[allow(clippy::too_many_arguments)]
    #[inline(always)]
    pub(super) fn walk<N: NodeStore, P: Primitives, C: Counters, S: HitSink>(
        &self,
        nodes: &N,
        prims: &P,
        ray: &Ray,
        pr: &PreparedRay,
        (t0, t1): (f32, f32),
        sink: &mut S,
        counters: &mut C,
    ) {
        let far_first = S::FIRST_ENDS && sink.walks_back();
        let pr = *pr;
        let o = ray.origin.to_array();
        let d = ray.dir.to_array();
        let inv = pr.inv_dir.to_array();
        let mut mail = Mailbox::default();
        // Left uninitialised, as the bvh's: zeroing 1.5 KB a ray costs more than a short walk.
        let mut stack =
            [const { std::mem::MaybeUninit::<(u32, f32, f32)>::uninit() }; 2 * MAX_DEPTH + 2];
        let mut top = 0;
        let (mut node, mut tn, mut tf) = (nodes.root(), t0, t1);
        loop {
            if tn <= sink.tmax() {
                counters.cell_visit(0);
                let (start, count) = match nodes.visit(node, &self.refs) {
                    Visit::Leaf { start, count } => (start, count),
                    Visit::Inner {
                        axis,
                        split,
                        below,
                        above,
                    } => {
                        // The side the ray is on before it crosses the plane, in increasing `t`:
                        // by the direction, not by the origin, since `[tn, tf]` may begin
                        // behind the origin (a negative `tmin`). Parallel to the plane, the
                        // origin's side.
                        let below_first = d[axis] > 0.0 || (d[axis] == 0.0 && o[axis] <= split);
                        let (first, second) = if below_first {
                            (below, above)
                        } else {
                            (above, below)
                        };
                        let ts = (split - o[axis]) * inv[axis];
                        // A ray parallel to the plane (`ts` infinite of either sign, or NaN in
                        // the plane) stays on the first side; no other `ts` is NaN.
                        if ts > tf || d[axis] == 0.0 {
                            node = first;
                        } else if ts < tn {
                            node = second;
                        } else if far_first {
                            // The far side first where the sink asks for it
                            // ([`crate::accel::HitSink::walked_back`]).
                            stack[top].write((first, tn, ts));
                            top += 1;
                            node = second;
                            tn = ts;
                        } else {
                            stack[top].write((second, ts, tf));
                            top += 1;
                            node = first;
                            tf = ts;
                        }
                        continue;
                    }
                };
                for &r in &self.refs[start..start + count] {
                    if !mail.first_visit(r) {
                        continue;
                    }
                    counters.prim_test(0);
                    if let Some(t) = self.store.intersect(prims, r, &pr, ray.tmin, sink.tmax()) {
                        counters.prim_hit(0);
                        if sink.offer(t, || self.store.id(r)) {
                            return;
                        }
                    }
                }
                // The nearest hit lies before the leaf's far end: nothing beyond it is nearer.
                // (Walked from the far end, the leaves beyond came first, and a hit has ended
                // the walk.)
                if !far_first && sink.tmax() <= tf {
                    break;
                }
            }
            if top == 0 {
                break;
            }
            top -= 1;
            // SAFETY: every entry below `top` has been written: `top` grows only by one, right
            // after `stack[top].write` (a bounds-checked index; one entry per inner node on the
            // way down of a tree at most `MAX_DEPTH` deep keeps it from panicking).
            (node, tn, tf) = unsafe { stack[top].assume_init() };
        }
    }

    /// Bytes of the nodes and leaf references, without the store.
    pub(super) fn structure_bytes(&self) -> usize {
        self.nodes.bytes() + self.refs.capacity() * 4
    }
}
