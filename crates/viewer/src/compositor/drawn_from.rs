//! What a cached pass was last drawn from (split out of mod.rs, which holds the compositor).

use super::lighting::FrameUniform;

/// What a cached pass (the loss maps, the radiosity maps, the shadows' second bounce) was last
/// drawn from: the frame uniform's bytes and the live meshes' uniforms. Empty: never drawn.
#[derive(Debug, Default)]
pub(super) struct DrawnFrom(std::cell::RefCell<Vec<u8>>);

impl DrawnFrom {
    fn key(uniform: &FrameUniform, mesh_bytes: &[u8]) -> Vec<u8> {
        let mut key = bytemuck::bytes_of(uniform).to_vec();
        key.extend_from_slice(mesh_bytes);
        key
    }

    /// Whether the pass was last drawn from `uniform` and `mesh_bytes`.
    pub(super) fn is_current(&self, uniform: &FrameUniform, mesh_bytes: &[u8]) -> bool {
        *self.0.borrow() == Self::key(uniform, mesh_bytes)
    }

    /// Forgets what the pass was drawn from: it is drawn again next time.
    pub(super) fn forget(&self) {
        self.0.borrow_mut().clear();
    }

    /// Whether the pass must be drawn again for `uniform` and `mesh_bytes`; if so, records them.
    pub(super) fn renew(&self, uniform: &FrameUniform, mesh_bytes: &[u8]) -> bool {
        let key = Self::key(uniform, mesh_bytes);
        if *self.0.borrow() == key {
            return false;
        }
        *self.0.borrow_mut() = key;
        true
    }
}
