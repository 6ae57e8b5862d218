//! The interactive viewer: the compositor's frames in a winit window (X11).
//!
//! The window's client area is the image's size and shows the composited frame pixel for
//! pixel (a `textureLoad` copy into a unorm surface: no filtering, no colour-space change), so
//! what a headless run writes is exactly what the window shows.
//!
//! Controls when no [`LiveUpdate`] drives the sphere, or when the one that does asks for them
//! ([`LiveUpdate::keyboard_moves_sphere`]; keys act on the sphere, in camera axes):
//! - mouse: left-drag moves the sphere under the cursor at its current depth; the wheel moves
//!   it along the view direction;
//! - arrows or `W`/`A`/`S`/`D`: move in the image plane; `Q`/`E` or `PageUp`/`PageDown`: move
//!   along the view direction (steps are 1% of the sphere's distance from the eye; hold `Shift`
//!   for 10%);
//! - `+`/`-`: grow or shrink the sphere;
//! - always: `M` switches the compositing mode, `P` prints the sphere's world position,
//!   `Escape` quits.

use crate::backdrop::Rgba8Image;
use crate::compositor::{CompositeMode, Compositor, CompositorSettings, FrameReadback};
use crate::error::ViewerError;
use crate::gpu::{Backends, Gpu};
use crate::live::{FrameInfo, LiveObjects, LiveUpdate};
use crate::scene::ViewerScene;
use glam::{DVec2, DVec3};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{ElementState, MouseButton, MouseScrollDelta, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{Key, ModifiersState, NamedKey};
use winit::window::{Window, WindowId};

/// How the window runs.
#[derive(Clone, Debug, Default)]
pub struct WindowSettings {
    pub title: String,
    /// Close after this many frames (`None`: run until closed).
    pub frames: Option<u64>,
    /// Write the last frame's colour here (PNG) on exit.
    pub screenshot: Option<PathBuf>,
    /// Write the last frame's live-object mask here (PNG) on exit.
    pub mask: Option<PathBuf>,
    pub backends: Backends,
}

/// What a window session ended with.
#[derive(Debug)]
pub struct WindowOutcome {
    /// Frames drawn.
    pub frames: u64,
    /// The last frame as presented, read back from the window's surface (when `frames` was
    /// given and the surface allows copies), cropped to the image.
    pub presented: Option<Rgba8Image>,
    /// The live objects at exit.
    pub live: LiveObjects,
    /// The adapter used.
    pub adapter: String,
}

struct Presenter {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    pipeline: wgpu::RenderPipeline,
    bind_group: wgpu::BindGroup,
    compositor: Compositor,
}

struct App {
    scene: ViewerScene,
    compositor_settings: CompositorSettings,
    settings: WindowSettings,
    live: LiveObjects,
    updater: Option<Box<dyn LiveUpdate>>,
    presenter: Option<Presenter>,
    error: Option<ViewerError>,
    frames: u64,
    start: Option<Instant>,
    modifiers: ModifiersState,
    dragging: bool,
    cursor: Option<DVec2>,
    dirty: bool,
    presented: Option<Rgba8Image>,
}

/// Opens a window showing `scene` with the live objects, and runs until it is closed (or for
/// `settings.frames` frames). `updater`, when given, moves the live objects each frame (a
/// haptic device); otherwise the keyboard and mouse move the sphere.
pub fn run(
    scene: ViewerScene,
    compositor_settings: CompositorSettings,
    settings: WindowSettings,
    live: LiveObjects,
    updater: Option<Box<dyn LiveUpdate>>,
) -> Result<WindowOutcome, ViewerError> {
    let mut builder = EventLoop::builder();
    // Tests run off the main thread; X11 allows that.
    winit::platform::x11::EventLoopBuilderExtX11::with_any_thread(&mut builder, true);
    let event_loop = builder.build().map_err(|e| ViewerError::Window(e.to_string()))?;
    let mut app = App {
        scene,
        compositor_settings,
        settings,
        live,
        updater,
        presenter: None,
        error: None,
        frames: 0,
        start: None,
        modifiers: ModifiersState::empty(),
        dragging: false,
        cursor: None,
        dirty: true,
        presented: None,
    };
    event_loop.run_app(&mut app).map_err(|e| ViewerError::Window(e.to_string()))?;
    if let Some(e) = app.error {
        return Err(e);
    }
    let adapter = app.presenter.as_ref().map(|p| p.compositor.gpu().describe()).unwrap_or_default();
    Ok(WindowOutcome { frames: app.frames, presented: app.presented, live: app.live, adapter })
}

impl App {
    fn fail(&mut self, event_loop: &ActiveEventLoop, e: ViewerError) {
        if self.error.is_none() {
            self.error = Some(e);
        }
        event_loop.exit();
    }

    fn create_presenter(&self, event_loop: &ActiveEventLoop) -> Result<Presenter, ViewerError> {
        let (w, h) = self.scene.size();
        let attributes = Window::default_attributes()
            .with_title(if self.settings.title.is_empty() {
                "hybrid-view".to_string()
            } else {
                self.settings.title.clone()
            })
            .with_inner_size(PhysicalSize::new(w, h))
            .with_resizable(false);
        let window =
            Arc::new(event_loop.create_window(attributes).map_err(|e| ViewerError::Window(e.to_string()))?);
        let mut desc =
            wgpu::InstanceDescriptor::new_with_display_handle(Box::new(event_loop.owned_display_handle()));
        desc.backends = self.settings.backends.0;
        let instance = wgpu::Instance::new(desc);
        let surface = instance
            .create_surface(window.clone())
            .map_err(|e| ViewerError::Window(format!("surface: {e}")))?;
        let gpu = Gpu::with_instance(instance, self.settings.backends, Some(&surface))?;
        let compositor = Compositor::new(&gpu, &self.scene, self.compositor_settings)?;

        let caps = surface.get_capabilities(&gpu.adapter);
        // A unorm (not sRGB) view, so the frame's bytes reach the screen unchanged.
        let format = caps
            .formats
            .iter()
            .copied()
            .find(|f| matches!(f, wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Rgba8Unorm))
            .or_else(|| caps.formats.first().copied())
            .ok_or_else(|| ViewerError::Window("the surface supports no format".into()))?;
        let view_format = format.remove_srgb_suffix();
        let size = window.inner_size();
        let present_mode = if caps.present_modes.contains(&wgpu::PresentMode::Mailbox) {
            wgpu::PresentMode::Mailbox
        } else {
            wgpu::PresentMode::Fifo
        };
        // Copies out of the surface let a fixed-length run read back what it presented.
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | (caps.usages & wgpu::TextureUsages::COPY_SRC);
        let config = wgpu::SurfaceConfiguration {
            usage,
            format,
            color_space: wgpu::SurfaceColorSpace::Auto,
            width: size.width.max(1),
            height: size.height.max(1),
            present_mode,
            desired_maximum_frame_latency: 2,
            alpha_mode: caps.alpha_modes.first().copied().unwrap_or(wgpu::CompositeAlphaMode::Auto),
            view_formats: if view_format == format { vec![] } else { vec![view_format] },
        };
        surface.configure(&gpu.device, &config);

        let device = &gpu.device;
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("present.wgsl"),
            source: wgpu::ShaderSource::Wgsl(include_str!("shaders/present.wgsl").into()),
        });
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("present"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: false },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
            }],
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("present"),
            layout: &layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(compositor.frame_view()),
            }],
        });
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("present"),
            layout: Some(&device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some("present"),
                bind_group_layouts: &[Some(&layout)],
                immediate_size: 0,
            })),
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_fullscreen"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil: None,
            multisample: wgpu::MultisampleState::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_present"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: view_format,
                    blend: None,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
        gpu.take_errors()?;
        Ok(Presenter { window, surface, config, pipeline, bind_group, compositor })
    }

    fn draw(&mut self, event_loop: &ActiveEventLoop) -> Result<(), ViewerError> {
        let start = *self.start.get_or_insert_with(Instant::now);
        let info = FrameInfo { index: self.frames, time_s: start.elapsed().as_secs_f64() };
        if let Some(updater) = self.updater.as_mut() {
            updater.update(&mut self.live, &info);
            if updater.wants_exit() {
                event_loop.exit();
            }
        }
        let Some(p) = self.presenter.as_mut() else { return Ok(()) };
        p.compositor.render(&self.live)?;
        let frame = match p.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t) | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Outdated | wgpu::CurrentSurfaceTexture::Lost => {
                let size = p.window.inner_size();
                p.config.width = size.width.max(1);
                p.config.height = size.height.max(1);
                p.surface.configure(&p.compositor.gpu().device, &p.config);
                self.dirty = true;
                return Ok(());
            }
            // Hidden or busy: skip this frame.
            _ => return Ok(()),
        };
        let view_format = p.config.format.remove_srgb_suffix();
        let view = frame
            .texture
            .create_view(&wgpu::TextureViewDescriptor { format: Some(view_format), ..Default::default() });
        let gpu = p.compositor.gpu();
        let mut encoder =
            gpu.device.create_command_encoder(&wgpu::CommandEncoderDescriptor { label: Some("present") });
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("present"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: wgpu::StoreOp::Store,
                    },
                })],
                depth_stencil_attachment: None,
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_pipeline(&p.pipeline);
            pass.set_bind_group(0, &p.bind_group, &[]);
            pass.draw(0..3, 0..1);
        }
        let last = self.settings.frames.is_some_and(|n| self.frames + 1 >= n);
        let capture = (last && p.config.usage.contains(wgpu::TextureUsages::COPY_SRC))
            .then(|| capture_surface(&mut encoder, gpu, &frame.texture, p.compositor.size()));
        gpu.queue.submit([encoder.finish()]);
        if let Some(capture) = capture {
            self.presented = Some(capture.finish(gpu, p.config.format)?);
        }
        p.window.pre_present_notify();
        gpu.queue.present(frame);
        gpu.take_errors()?;
        self.frames += 1;
        self.dirty = false;
        if self.settings.frames.is_some_and(|n| self.frames >= n) {
            event_loop.exit();
        }
        Ok(())
    }

    fn write_outputs(&self) -> Result<(), ViewerError> {
        let Some(p) = self.presenter.as_ref() else { return Ok(()) };
        if self.settings.screenshot.is_none() && self.settings.mask.is_none() {
            return Ok(());
        }
        let frame: FrameReadback = p.compositor.read_back()?;
        if let Some(path) = &self.settings.screenshot {
            if crate::compositor::is_exr_path(path) {
                p.compositor.read_back_linear()?.write_exr(path)?;
            } else {
                // What the window showed when it was read back, else the frame it was given.
                self.presented.as_ref().unwrap_or(&frame.colour).write_png(path)?;
            }
        }
        if let Some(path) = &self.settings.mask {
            frame.write_mask_png(path)?;
        }
        Ok(())
    }

    /// Moves the sphere by `delta` in camera space.
    fn move_sphere_camera(&mut self, delta: DVec3) {
        let camera = self.scene.camera();
        if let Some(s) = self.live.sphere.as_mut() {
            s.centre = moved_in_camera_axes(camera, s.centre, delta);
            self.dirty = true;
        }
    }

    /// The sphere's eye depth, for step sizes and dragging.
    fn sphere_eye_depth(&self) -> Option<f64> {
        let s = self.live.sphere.as_ref()?;
        Some(self.scene.camera().camera_from_world().transform_point3(s.centre).z)
    }

    fn step(&self) -> f64 {
        let base = self.sphere_eye_depth().map(f64::abs).filter(|z| *z > 0.0).unwrap_or(1.0) * 0.01;
        if self.modifiers.shift_key() { base * 10.0 } else { base }
    }

    /// Puts the sphere under the cursor, keeping its eye depth.
    fn drag_to(&mut self, cursor: DVec2) {
        let camera = self.scene.camera();
        if let Some(s) = self.live.sphere.as_mut()
            && let Some(c) = under_cursor(camera, s.centre, cursor)
        {
            s.centre = c;
            self.dirty = true;
        }
    }

    /// Whether the keyboard and mouse move the sphere: always without an updater, and with one
    /// that asks for it.
    fn keyboard_moves_sphere(&self) -> bool {
        self.updater.as_ref().is_none_or(|u| u.keyboard_moves_sphere())
    }

    fn key(&mut self, event_loop: &ActiveEventLoop, key: &Key) {
        let manual = self.keyboard_moves_sphere();
        let step = self.step();
        match key {
            Key::Named(NamedKey::Escape) => event_loop.exit(),
            Key::Named(NamedKey::ArrowLeft) if manual => self.move_sphere_camera(DVec3::new(-step, 0.0, 0.0)),
            Key::Named(NamedKey::ArrowRight) if manual => self.move_sphere_camera(DVec3::new(step, 0.0, 0.0)),
            Key::Named(NamedKey::ArrowUp) if manual => self.move_sphere_camera(DVec3::new(0.0, step, 0.0)),
            Key::Named(NamedKey::ArrowDown) if manual => self.move_sphere_camera(DVec3::new(0.0, -step, 0.0)),
            Key::Named(NamedKey::PageUp) if manual => self.move_sphere_camera(DVec3::new(0.0, 0.0, step)),
            Key::Named(NamedKey::PageDown) if manual => self.move_sphere_camera(DVec3::new(0.0, 0.0, -step)),
            Key::Character(c) => match c.to_lowercase().as_str() {
                "a" if manual => self.move_sphere_camera(DVec3::new(-step, 0.0, 0.0)),
                "d" if manual => self.move_sphere_camera(DVec3::new(step, 0.0, 0.0)),
                "w" if manual => self.move_sphere_camera(DVec3::new(0.0, step, 0.0)),
                "s" if manual => self.move_sphere_camera(DVec3::new(0.0, -step, 0.0)),
                "e" if manual => self.move_sphere_camera(DVec3::new(0.0, 0.0, step)),
                "q" if manual => self.move_sphere_camera(DVec3::new(0.0, 0.0, -step)),
                "+" | "=" if manual => {
                    if let Some(s) = self.live.sphere.as_mut() {
                        s.radius *= 1.1;
                        self.dirty = true;
                    }
                }
                "-" if manual => {
                    if let Some(s) = self.live.sphere.as_mut() {
                        s.radius /= 1.1;
                        self.dirty = true;
                    }
                }
                "m" => {
                    if let Some(p) = self.presenter.as_mut() {
                        let next = match p.compositor.mode() {
                            CompositeMode::Points => CompositeMode::Fullscreen,
                            CompositeMode::Fullscreen => CompositeMode::Points,
                        };
                        p.compositor.set_mode(next);
                        println!("compositing mode: {}", next.name());
                        self.dirty = true;
                    }
                }
                "p" => {
                    if let Some(s) = &self.live.sphere {
                        println!(
                            "sphere at {},{},{} radius {}",
                            s.centre.x, s.centre.y, s.centre.z, s.radius
                        );
                    }
                }
                _ => {}
            },
            _ => {}
        }
    }
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.presenter.is_some() {
            return;
        }
        match self.create_presenter(event_loop) {
            Ok(p) => {
                p.window.request_redraw();
                self.presenter = Some(p);
            }
            Err(e) => self.fail(event_loop, e),
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::RedrawRequested => {
                if let Err(e) = self.draw(event_loop) {
                    self.fail(event_loop, e);
                }
            }
            WindowEvent::Resized(size) => {
                if let Some(p) = self.presenter.as_mut() {
                    p.config.width = size.width.max(1);
                    p.config.height = size.height.max(1);
                    p.surface.configure(&p.compositor.gpu().device, &p.config);
                }
                self.dirty = true;
            }
            WindowEvent::ModifiersChanged(m) => self.modifiers = m.state(),
            WindowEvent::KeyboardInput { event, .. } if event.state == ElementState::Pressed => {
                self.key(event_loop, &event.logical_key);
            }
            WindowEvent::MouseInput { state, button: MouseButton::Left, .. } => {
                self.dragging = state == ElementState::Pressed && self.keyboard_moves_sphere();
                if let (true, Some(c)) = (self.dragging, self.cursor) {
                    self.drag_to(c);
                }
            }
            WindowEvent::CursorMoved { position, .. } => {
                let c = DVec2::new(position.x, position.y);
                self.cursor = Some(c);
                if self.dragging {
                    self.drag_to(c);
                }
            }
            WindowEvent::MouseWheel { delta, .. } if self.keyboard_moves_sphere() => {
                let lines = match delta {
                    MouseScrollDelta::LineDelta(_, y) => f64::from(y),
                    MouseScrollDelta::PixelDelta(p) => p.y / 40.0,
                };
                let step = self.step();
                self.move_sphere_camera(DVec3::new(0.0, 0.0, -lines * step));
            }
            _ => {}
        }
    }

    fn about_to_wait(&mut self, event_loop: &ActiveEventLoop) {
        // A driven sphere moves every frame, and a fixed frame count must be reached: keep
        // drawing. Otherwise draw only when something changed.
        let continuous = self.updater.is_some() || self.settings.frames.is_some();
        if let Some(p) = self.presenter.as_ref()
            && (continuous || self.dirty)
        {
            p.window.request_redraw();
        }
        if continuous {
            event_loop.set_control_flow(ControlFlow::Poll);
        } else {
            event_loop.set_control_flow(ControlFlow::WaitUntil(Instant::now() + Duration::from_millis(100)));
        }
    }

    fn exiting(&mut self, _event_loop: &ActiveEventLoop) {
        if self.error.is_none()
            && let Err(e) = self.write_outputs()
        {
            self.error = Some(e);
        }
    }
}

/// `world` moved by `delta` along the camera's axes (x right, y up, z forward).
pub fn moved_in_camera_axes(camera: &depth_remap::Camera, world: DVec3, delta: DVec3) -> DVec3 {
    let c = camera.camera_from_world().transform_point3(world) + delta;
    camera.world_from_camera().transform_point3(c)
}

/// The point at `world`'s eye depth on the ray through raster position `cursor`: where a drag
/// puts the sphere so it stays under the mouse. `None` when that depth is behind the eye.
pub fn under_cursor(camera: &depth_remap::Camera, world: DVec3, cursor: DVec2) -> Option<DVec3> {
    let z = camera.camera_from_world().transform_point3(world).z;
    let ray = camera.ray_through_raster(cursor);
    let t = (z - ray.origin.z) / ray.direction.z;
    if !(t > 0.0 && t.is_finite()) {
        return None;
    }
    Some(camera.world_from_camera().transform_point3(ray.origin + ray.direction * t))
}

/// A pending copy of the surface texture into a mappable buffer.
struct SurfaceCapture {
    buffer: wgpu::Buffer,
    padded_row: u32,
    width: u32,
    height: u32,
}

fn capture_surface(
    encoder: &mut wgpu::CommandEncoder,
    gpu: &Gpu,
    texture: &wgpu::Texture,
    (image_w, image_h): (u32, u32),
) -> SurfaceCapture {
    let width = image_w.min(texture.width());
    let height = image_h.min(texture.height());
    let padded_row = (width * 4).div_ceil(256) * 256;
    let buffer = gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("surface capture"),
        size: u64::from(padded_row) * u64::from(height),
        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
        mapped_at_creation: false,
    });
    encoder.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded_row),
                rows_per_image: Some(height),
            },
        },
        wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
    );
    SurfaceCapture { buffer, padded_row, width, height }
}

impl SurfaceCapture {
    /// Waits for the copy and returns the pixels as RGBA.
    fn finish(self, gpu: &Gpu, format: wgpu::TextureFormat) -> Result<Rgba8Image, ViewerError> {
        let (tx, rx) = std::sync::mpsc::channel();
        self.buffer.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        gpu.device.poll(wgpu::PollType::wait_indefinitely()).map_err(|e| ViewerError::Gpu(e.to_string()))?;
        rx.recv()
            .map_err(|e| ViewerError::Gpu(e.to_string()))?
            .map_err(|e| ViewerError::Gpu(format!("mapping the surface capture: {e}")))?;
        let view = self.buffer.get_mapped_range(..).map_err(|e| ViewerError::Gpu(e.to_string()))?;
        let bgra = matches!(format.remove_srgb_suffix(), wgpu::TextureFormat::Bgra8Unorm);
        let mut pixels = Vec::with_capacity(self.width as usize * self.height as usize * 4);
        for row in 0..self.height as usize {
            let start = row * self.padded_row as usize;
            for px in view[start..start + self.width as usize * 4].chunks_exact(4) {
                if bgra {
                    pixels.extend_from_slice(&[px[2], px[1], px[0], px[3]]);
                } else {
                    pixels.extend_from_slice(px);
                }
            }
        }
        Ok(Rgba8Image { width: self.width, height: self.height, pixels })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use depth_remap::{Camera, CameraSettings, Projection};
    use glam::DMat4;

    fn camera() -> Camera {
        // The Cornell camera: a mirror and a translation.
        Camera::new(CameraSettings {
            x_resolution: 320,
            y_resolution: 240,
            projection: Projection::Perspective { fov_degrees: 40.0 },
            camera_from_world: DMat4::from_scale(DVec3::new(1.0, 1.0, -1.0))
                * DMat4::from_translation(DVec3::new(0.0, 0.0, -3.9)),
            ..CameraSettings::default()
        })
        .unwrap()
    }

    #[test]
    fn dragging_keeps_the_sphere_under_the_cursor_at_its_depth() {
        let cam = camera();
        let start = DVec3::new(0.2, -0.1, 0.5);
        let cursor = DVec2::new(250.25, 31.5);
        let moved = under_cursor(&cam, start, cursor).unwrap();
        let (raster, depth) = cam.world_to_raster(moved).unwrap();
        assert!((raster - cursor).length() < 1e-9, "{raster}");
        let z = |p: DVec3| cam.camera_from_world().transform_point3(p).z;
        assert!((z(moved) - z(start)).abs() < 1e-12 && depth > 0.0);
        // Behind the eye there is nothing to drag to.
        assert!(under_cursor(&cam, DVec3::new(0.0, 0.0, 5.0), cursor).is_none());
    }

    #[test]
    fn key_moves_follow_the_camera_axes() {
        let cam = camera();
        let start = DVec3::new(0.2, -0.1, 0.5);
        // Camera +x is world +x, camera +z (forward) is world -z for this mirrored camera.
        let right = moved_in_camera_axes(&cam, start, DVec3::new(0.1, 0.0, 0.0));
        assert!((right - DVec3::new(0.3, -0.1, 0.5)).length() < 1e-12);
        let forward = moved_in_camera_axes(&cam, start, DVec3::new(0.0, 0.0, 0.1));
        assert!((forward - DVec3::new(0.2, -0.1, 0.4)).length() < 1e-12);
    }
}
