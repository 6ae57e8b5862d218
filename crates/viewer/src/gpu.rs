//! Finding a GPU (a software one counts) and opening a device on it.

use crate::error::ViewerError;
use std::sync::{Arc, Mutex};

/// A wgpu device and queue with the adapter they came from.
#[derive(Debug, Clone)]
pub struct Gpu {
    pub instance: wgpu::Instance,
    pub adapter: wgpu::Adapter,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    errors: Arc<Mutex<Vec<String>>>,
}

/// Which backends to try. `WGPU_BACKEND` (e.g. `vulkan`, `gl`) overrides [`Backends::default`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Backends(pub wgpu::Backends);

impl Default for Backends {
    /// Vulkan (real GPUs and lavapipe) first, then GL (llvmpipe).
    fn default() -> Self {
        Backends(wgpu::Backends::from_env().unwrap_or(wgpu::Backends::VULKAN | wgpu::Backends::GL))
    }
}

impl Gpu {
    /// Opens a device for offscreen rendering on the best adapter: a Vulkan adapter before a GL
    /// one, a hardware adapter before a software one. Fails (never falls back to doing nothing)
    /// when there is none.
    pub fn new(backends: Backends) -> Result<Gpu, ViewerError> {
        // Vulkan alone first: probing GL (EGL) is slow and noisy, and only needed without Vulkan.
        let vulkan = backends.0 & wgpu::Backends::VULKAN;
        let others = backends.0 - wgpu::Backends::VULKAN;
        let mut last_error = None;
        for phase in [vulkan, others] {
            if phase.is_empty() {
                continue;
            }
            let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
            desc.backends = phase;
            match Self::with_instance(wgpu::Instance::new(desc), Backends(phase), None) {
                Ok(gpu) => return Ok(gpu),
                Err(e) => last_error = Some(e),
            }
        }
        Err(last_error.unwrap_or_else(|| ViewerError::NoAdapter("no backend was allowed".into())))
    }

    /// Opens a device on an adapter that can present to `surface`.
    pub fn with_instance(
        instance: wgpu::Instance,
        backends: Backends,
        surface: Option<&wgpu::Surface<'_>>,
    ) -> Result<Gpu, ViewerError> {
        let adapters = pollster::block_on(instance.enumerate_adapters(backends.0));
        let mut candidates: Vec<wgpu::Adapter> = adapters
            .into_iter()
            .filter(|a| surface.is_none_or(|s| a.is_surface_supported(s)))
            // Vertex storage: the vertex shaders read the frame's parameters from a storage buffer
            // (composite.wgsl).
            .filter(|a| {
                let flags = a.get_downlevel_capabilities().flags;
                flags.contains(wgpu::DownlevelFlags::COMPUTE_SHADERS | wgpu::DownlevelFlags::VERTEX_STORAGE)
            })
            .collect();
        candidates.sort_by_key(|a| {
            let info = a.get_info();
            let backend_rank = match info.backend {
                wgpu::Backend::Vulkan => 0,
                wgpu::Backend::Metal | wgpu::Backend::Dx12 => 1,
                _ => 2,
            };
            let type_rank = match info.device_type {
                wgpu::DeviceType::DiscreteGpu => 0,
                wgpu::DeviceType::IntegratedGpu => 1,
                wgpu::DeviceType::VirtualGpu => 2,
                wgpu::DeviceType::Cpu => 3,
                wgpu::DeviceType::Other => 4,
            };
            (backend_rank, type_rank)
        });
        let adapter = candidates.into_iter().next().ok_or_else(|| {
            ViewerError::NoAdapter(format!(
                "no {:?} adapter with compute shaders and storage buffers in vertex shaders; install a Vulkan driver (e.g. mesa-vulkan-drivers for lavapipe)",
                backends.0
            ))
        })?;
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("viewer"),
            required_features: wgpu::Features::empty(),
            required_limits: limits,
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        }))
        .map_err(|e| ViewerError::Gpu(format!("cannot open a device on {}: {e}", adapter.get_info().name)))?;
        let errors = Arc::new(Mutex::new(Vec::new()));
        let sink = errors.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut v) = sink.lock() {
                v.push(e.to_string());
            }
        }));
        Ok(Gpu { instance, adapter, device, queue, errors })
    }

    /// A one-line description of the adapter: name, backend, device type, driver.
    pub fn describe(&self) -> String {
        let i = self.adapter.get_info();
        format!("{} ({:?}, {:?}, {} {})", i.name, i.backend, i.device_type, i.driver, i.driver_info)
    }

    /// Returns (and clears) the errors wgpu reported since the last call, as one error.
    pub fn take_errors(&self) -> Result<(), ViewerError> {
        let mut v = self.errors.lock().map_err(|_| ViewerError::Gpu("error log poisoned".into()))?;
        if v.is_empty() {
            Ok(())
        } else {
            let message = v.join("; ");
            v.clear();
            Err(ViewerError::Gpu(message))
        }
    }
}
