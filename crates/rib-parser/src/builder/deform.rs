//! Deformation motion blocks: `MotionBegin [t0 t1 ...]` around one geometry request per time.
//! The first request's shapes were added when it came; at `MotionEnd` the later requests become
//! their keys ([`Deformation`]) when they match, and each shape is replaced by its value at
//! shutter open. Keys that do not match leave the first request as it is, with a warning at the
//! request that differs.

use super::{Motion, SceneBuilder};
use crate::deformation::{Deformation, mismatch};
use crate::diagnostics::DiagnosticKind;
use crate::target::Cx;
use std::sync::Arc;

impl SceneBuilder {
    pub(super) fn deform(&mut self, motion: Motion, cx: &mut Cx<'_>) {
        let requests = motion.later_shapes.len() + 1;
        let Some(first) = motion.first_shapes else {
            self.warn_once(
                "deformation-in-object",
                cx,
                DiagnosticKind::Unsupported,
                "deformation motion blur inside ObjectBegin/ObjectEnd is not supported: the first key is used",
            );
            return;
        };
        if requests != motion.times.len() {
            cx.warn(
                DiagnosticKind::BadArguments,
                format!(
                    "MotionBegin gives {} times but the block has {requests} geometry requests; the first is used, without deformation blur",
                    motion.times.len()
                ),
            );
            return;
        }
        let open = self.shutter_open();
        let Some(world) = self.world.as_mut() else { return };
        let count = world.shapes.len() - first;
        // Every request must make as many shapes (one, or 32 for `Geometry "teapot"`).
        let mut keys: Vec<Vec<Arc<crate::scene::Shape>>> =
            (0..count).map(|j| vec![world.shapes[first + j].shape.clone()]).collect();
        let mut locs = Vec::with_capacity(requests - 1);
        for (shapes, loc) in motion.later_shapes {
            if shapes.len() != count {
                cx.diagnostics.warn(
                    DiagnosticKind::BadArguments,
                    &loc,
                    format!(
                        "this deformation key makes {} shapes, the first made {count}: the first key is used, without deformation blur",
                        shapes.len()
                    ),
                );
                return;
            }
            for (j, shape) in shapes.into_iter().enumerate() {
                keys[j].push(Arc::new(shape));
            }
            locs.push(loc);
        }
        // A key that does not match is reported where it was given.
        for key in &keys {
            for (shape, loc) in key[1..].iter().zip(&locs) {
                if let Some(why) = mismatch(&key[0], shape) {
                    cx.diagnostics.warn(
                        DiagnosticKind::BadArguments,
                        loc,
                        format!(
                            "this geometry cannot be a deformation key of the first in its motion block ({why}): the first key is used, without deformation blur"
                        ),
                    );
                    return;
                }
            }
        }
        let mut deformations = Vec::with_capacity(count);
        for key in keys {
            match Deformation::new(motion.times.clone(), key) {
                Ok(d) => deformations.push(d),
                Err(why) => {
                    cx.warn(
                        DiagnosticKind::BadArguments,
                        format!(
                            "the geometry inside this motion block cannot deform ({why}): the first key is used, without deformation blur"
                        ),
                    );
                    return;
                }
            }
        }
        for (j, d) in deformations.into_iter().enumerate() {
            if d.is_static() {
                continue;
            }
            let entity = &mut world.shapes[first + j];
            entity.shape = Arc::new(d.at(open));
            entity.deformation = Some(Arc::new(d));
        }
    }
}
