//! 3Dconnexion SpaceMouse-family 6-DoF input devices through hidapi (raw HID, no driver or
//! daemon needed), used as a position or rate controller of the proxy's goal.
//!
//! ## Reports
//! The devices send numbered HID input reports (first byte = report id), values little-endian
//! `i16`, about +-350 at full deflection:
//! - id 1, 7 bytes: translation `x, y, z`;
//! - id 1, 13 bytes (newer wireless models and the Universal Receiver): translation **and**
//!   rotation `x, y, z, rx, ry, rz` in one report;
//! - id 2, 7 bytes: rotation `rx, ry, rz` (older and wired models);
//! - id 3: button bitmap, bit `i` = button `i`, little-endian over the following bytes;
//! - anything else (battery level 0x17, ...) is ignored.
//!
//! The HID axes are x right, y towards the user, z down. They are first turned into the **cap
//! frame**: x right, y up, z towards the user (the viewer's eye frame, right-handed), then into
//! the device frame by [`SpaceMouseSettings::device_from_cap`]. A front end that knows the
//! camera sets it so that pushing the cap away moves the cursor into the screen whatever the
//! scene's axes (see [`device_from_cap_for_camera`]); the identity keeps the cap frame.
//!
//! ## Controllers
//! - **Position**: the cap's deflection is the position, scaled so full deflection reaches the
//!   workspace radius; releasing the cap recentres.
//! - **Rate**: the deflection is a velocity; the position integrates it inside the workspace.
//!   The rendered force is fed back as an admittance (velocity += force / feedback damping), so
//!   a goal pushed into a surface drifts back out to the proxy when the cap is released,
//!   instead of staying buried.
//!
//! The reports are read on a separate thread (HID delivers them at about 60-125 Hz, and a read
//! must never stall the haptic loop); the haptic loop picks up the latest through a triple
//! buffer. When the device is unplugged the read fails, and the next `read` of the haptic loop
//! returns [`DeviceError::Disconnected`], which stops the loop cleanly.

use super::{DeviceError, DeviceSample, DeviceSpecs, HapticDevice, SafeForce};
use crate::triple_buffer::{self, Reader, Writer};
use glam::{DMat3, DQuat, DVec3};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;

/// Logitech's vendor id, under which 3Dconnexion's older devices were sold.
pub const VENDOR_LOGITECH: u16 = 0x046d;
/// 3Dconnexion's own vendor id.
pub const VENDOR_3DCONNEXION: u16 = 0x256f;

/// Known 6-DoF products: (vendor, product, name). Logitech's vendor id covers many unrelated
/// devices, so only these products count for it; any 3Dconnexion product that presents a
/// multi-axis controller counts.
pub const KNOWN_PRODUCTS: &[(u16, u16, &str)] = &[
    (VENDOR_LOGITECH, 0xc603, "SpaceMouse Plus USB"),
    (VENDOR_LOGITECH, 0xc605, "CadMan"),
    (VENDOR_LOGITECH, 0xc606, "SpaceMouse Classic USB"),
    (VENDOR_LOGITECH, 0xc621, "SpaceBall 5000 USB"),
    (VENDOR_LOGITECH, 0xc623, "SpaceTraveler"),
    (VENDOR_LOGITECH, 0xc625, "SpacePilot"),
    (VENDOR_LOGITECH, 0xc626, "SpaceNavigator"),
    (VENDOR_LOGITECH, 0xc627, "SpaceExplorer"),
    (VENDOR_LOGITECH, 0xc628, "SpaceNavigator for Notebooks"),
    (VENDOR_LOGITECH, 0xc629, "SpacePilot Pro"),
    (VENDOR_LOGITECH, 0xc62b, "SpaceMouse Pro"),
    (VENDOR_3DCONNEXION, 0xc62e, "SpaceMouse Wireless (cable)"),
    (VENDOR_3DCONNEXION, 0xc62f, "SpaceMouse Wireless (receiver)"),
    (VENDOR_3DCONNEXION, 0xc631, "SpaceMouse Pro Wireless (cable)"),
    (VENDOR_3DCONNEXION, 0xc632, "SpaceMouse Pro Wireless (receiver)"),
    (VENDOR_3DCONNEXION, 0xc633, "SpaceMouse Enterprise"),
    (VENDOR_3DCONNEXION, 0xc635, "SpaceMouse Compact"),
    (VENDOR_3DCONNEXION, 0xc636, "SpaceMouse Module"),
    (VENDOR_3DCONNEXION, 0xc638, "SpaceMouse Pro Wireless (Bluetooth)"),
    (VENDOR_3DCONNEXION, 0xc63a, "SpaceMouse Wireless"),
    (VENDOR_3DCONNEXION, 0xc641, "SpaceMouse USB"),
    (VENDOR_3DCONNEXION, 0xc652, "3Dconnexion Universal Receiver"),
];

/// HID usage page and usage of a multi-axis controller (Generic Desktop / Multi-axis).
const USAGE_PAGE_GENERIC_DESKTOP: u16 = 0x01;
const USAGE_MULTI_AXIS_CONTROLLER: u16 = 0x08;

/// Whether a HID interface is a SpaceMouse-family 6-DoF controller. `usage_page` 0 means the
/// back end did not report usages.
pub fn is_spacemouse(vendor_id: u16, product_id: u16, usage_page: u16, usage: u16) -> bool {
    let known = KNOWN_PRODUCTS.iter().any(|&(v, p, _)| v == vendor_id && p == product_id);
    let family = known || vendor_id == VENDOR_3DCONNEXION;
    let multi_axis =
        usage_page == 0 || (usage_page == USAGE_PAGE_GENERIC_DESKTOP && usage == USAGE_MULTI_AXIS_CONTROLLER);
    family && multi_axis
}

/// The product's name from [`KNOWN_PRODUCTS`].
pub fn product_name(vendor_id: u16, product_id: u16) -> Option<&'static str> {
    KNOWN_PRODUCTS.iter().find(|&&(v, p, _)| v == vendor_id && p == product_id).map(|&(_, _, n)| n)
}

/// One decoded input report.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Report {
    Translation([i16; 3]),
    Rotation([i16; 3]),
    /// The single 13-byte report of newer wireless models.
    Motion {
        translation: [i16; 3],
        rotation: [i16; 3],
    },
    Buttons(u32),
}

fn axes(bytes: &[u8]) -> [i16; 3] {
    [
        i16::from_le_bytes([bytes[0], bytes[1]]),
        i16::from_le_bytes([bytes[2], bytes[3]]),
        i16::from_le_bytes([bytes[4], bytes[5]]),
    ]
}

/// Decodes one report as hidapi returns it (report id first); `None` for reports that carry
/// nothing this crate uses or are too short.
pub fn decode_report(bytes: &[u8]) -> Option<Report> {
    match *bytes.first()? {
        1 if bytes.len() >= 13 => {
            Some(Report::Motion { translation: axes(&bytes[1..7]), rotation: axes(&bytes[7..13]) })
        }
        1 if bytes.len() >= 7 => Some(Report::Translation(axes(&bytes[1..7]))),
        2 if bytes.len() >= 7 => Some(Report::Rotation(axes(&bytes[1..7]))),
        3 if bytes.len() >= 2 => {
            let mut buttons = 0u32;
            for (i, &b) in bytes[1..].iter().take(4).enumerate() {
                buttons |= (b as u32) << (8 * i);
            }
            Some(Report::Buttons(buttons))
        }
        _ => None,
    }
}

/// The latest raw state of the cap and buttons.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct RawState {
    pub translation: [i16; 3],
    pub rotation: [i16; 3],
    pub buttons: u32,
    /// Reports received so far.
    pub reports: u64,
    /// The device failed; the reason is in the shared error slot.
    pub failed: bool,
}

impl RawState {
    pub fn apply(&mut self, report: Report) {
        match report {
            Report::Translation(t) => self.translation = t,
            Report::Rotation(r) => self.rotation = r,
            Report::Motion { translation, rotation } => {
                self.translation = translation;
                self.rotation = rotation;
            }
            Report::Buttons(b) => self.buttons = b,
        }
        self.reports += 1;
    }
}

/// HID axes (x right, y towards the user, z down) to the cap frame (x right, y up, z towards
/// the user).
fn cap_frame([x, y, z]: [i16; 3]) -> DVec3 {
    DVec3::new(x as f64, -(z as f64), y as f64)
}

/// The `device_from_cap` rotation that makes the cap move the cursor in the view: right on the
/// screen, up on the screen, and towards the viewer, for a RenderMan camera whose
/// `world_from_camera` linear part is given (camera space: x right, y up, z into the screen).
/// With `scene = centre + gain * device`, device axes are world axes.
pub fn device_from_cap_for_camera(world_from_camera: DMat3) -> DMat3 {
    // Cap z (towards the viewer) is camera -z; normalise away any scale in the camera.
    let cols = [world_from_camera.x_axis, world_from_camera.y_axis, -world_from_camera.z_axis];
    let unit = |v: DVec3| v.normalize_or(DVec3::ZERO);
    DMat3::from_cols(unit(cols[0]), unit(cols[1]), unit(cols[2]))
}

/// How the cap drives the goal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ControlMode {
    Position,
    Rate,
}

/// Settings of the SpaceMouse controller.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpaceMouseSettings {
    pub mode: ControlMode,
    /// Counts at full deflection.
    pub full_scale: f64,
    /// Counts below which an axis reads as zero (the cap never rests exactly at 0).
    pub deadband: f64,
    /// Radius the goal can reach (m).
    pub workspace_radius: f64,
    /// Rate mode: speed at full deflection (m/s).
    pub speed: f64,
    /// Rate mode: angular speed at full deflection (rad/s).
    pub angular_speed: f64,
    /// Position mode: rotation at full deflection (rad).
    pub max_angle: f64,
    /// Rate mode: damping of the force feedback admittance (N s/m); velocity += force / this.
    pub feedback_damping: f64,
    /// From the cap frame (x right, y up, z towards the user) to the device frame.
    pub device_from_cap: DMat3,
    /// Rate mode: where the integrated position starts (device frame, inside the workspace),
    /// e.g. a point in free space in view rather than the workspace centre.
    pub rate_start: DVec3,
}

impl Default for SpaceMouseSettings {
    fn default() -> SpaceMouseSettings {
        SpaceMouseSettings {
            mode: ControlMode::Rate,
            full_scale: 350.0,
            deadband: 8.0,
            workspace_radius: 0.08,
            speed: 0.1,
            angular_speed: 1.5,
            max_angle: 0.8,
            feedback_damping: 50.0,
            device_from_cap: DMat3::IDENTITY,
            rate_start: DVec3::ZERO,
        }
    }
}

/// Turns raw cap states into device positions: shared by the hidapi device and the tests.
#[derive(Clone, Debug, PartialEq)]
pub struct Controller {
    settings: SpaceMouseSettings,
    position: DVec3,
    orientation: DQuat,
    last_time: Option<f64>,
    force: DVec3,
}

impl Controller {
    pub fn new(settings: SpaceMouseSettings) -> Controller {
        let start = match settings.mode {
            ControlMode::Rate if settings.rate_start.is_finite() => {
                settings.rate_start.clamp_length_max(settings.workspace_radius.max(0.0))
            }
            _ => DVec3::ZERO,
        };
        Controller {
            settings,
            position: start,
            orientation: DQuat::IDENTITY,
            last_time: None,
            force: DVec3::ZERO,
        }
    }

    fn normalised(&self, v: DVec3) -> DVec3 {
        let s = &self.settings;
        let dead = |c: f64| {
            if c.abs() <= s.deadband {
                0.0
            } else {
                (c - s.deadband * c.signum()) / (s.full_scale - s.deadband)
            }
        };
        let v = DVec3::new(dead(v.x), dead(v.y), dead(v.z));
        v.clamp(DVec3::splat(-1.0), DVec3::splat(1.0))
    }

    /// Sets the rendered force fed back in rate mode.
    pub fn set_force(&mut self, force: DVec3) {
        self.force = if force.is_finite() { force } else { DVec3::ZERO };
    }

    /// Advances to loop time `time` with the cap in state `raw`.
    pub fn update(&mut self, raw: &RawState, time: f64) -> (DVec3, DQuat) {
        let s = self.settings;
        let turn = s.device_from_cap;
        // Rotation vectors are axial: a mirror in `device_from_cap` flips them once more.
        let axial = if turn.determinant() < 0.0 { -1.0 } else { 1.0 };
        let translation = turn * self.normalised(cap_frame(raw.translation));
        let rotation = turn * self.normalised(cap_frame(raw.rotation)) * axial;
        let dt = match self.last_time {
            Some(t0) if time > t0 => (time - t0).min(0.05),
            _ => 0.0,
        };
        self.last_time = Some(time);
        match s.mode {
            ControlMode::Position => {
                self.position = translation * s.workspace_radius;
                self.orientation = DQuat::from_scaled_axis(rotation * s.max_angle);
            }
            ControlMode::Rate => {
                let feedback =
                    if s.feedback_damping > 0.0 { self.force / s.feedback_damping } else { DVec3::ZERO };
                self.position += (translation * s.speed + feedback) * dt;
                self.orientation = (DQuat::from_scaled_axis(rotation * (s.angular_speed * dt))
                    * self.orientation)
                    .normalize();
            }
        }
        let length = self.position.length();
        if length > s.workspace_radius {
            self.position *= s.workspace_radius / length;
        }
        (self.position, self.orientation)
    }
}

/// Where reports come from: a HID device, or a script in tests.
pub trait ReportSource: Send + 'static {
    /// Reads one report into `buf` waiting at most `timeout_ms`; `Ok(0)` on timeout, `Err` when
    /// the device is gone.
    fn read_report(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<usize, String>;
}

struct HidSource(hidapi::HidDevice);

impl ReportSource for HidSource {
    fn read_report(&mut self, buf: &mut [u8], timeout_ms: i32) -> Result<usize, String> {
        self.0.read_timeout(buf, timeout_ms).map_err(|e| e.to_string())
    }
}

/// A connected SpaceMouse-family device.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SpaceMouseInfo {
    pub path: String,
    pub name: String,
    pub vendor_id: u16,
    pub product_id: u16,
}

fn hid_error(detail: impl std::fmt::Display) -> DeviceError {
    DeviceError::Io { device: "hidapi".into(), detail: detail.to_string() }
}

/// The SpaceMouse-family devices connected now.
pub fn enumerate() -> Result<Vec<SpaceMouseInfo>, DeviceError> {
    let api = hidapi::HidApi::new().map_err(hid_error)?;
    let mut found: Vec<SpaceMouseInfo> = Vec::new();
    for d in api.device_list() {
        if !is_spacemouse(d.vendor_id(), d.product_id(), d.usage_page(), d.usage()) {
            continue;
        }
        let path = d.path().to_string_lossy().into_owned();
        if found.iter().any(|f| f.path == path) {
            continue;
        }
        let name = d
            .product_string()
            .map(str::to_owned)
            .or_else(|| product_name(d.vendor_id(), d.product_id()).map(str::to_owned))
            .unwrap_or_else(|| format!("3Dconnexion device {:04x}", d.product_id()));
        found.push(SpaceMouseInfo { path, name, vendor_id: d.vendor_id(), product_id: d.product_id() });
    }
    Ok(found)
}

/// A SpaceMouse driving the proxy's goal. See the module documentation.
#[derive(Debug)]
pub struct SpaceMouse {
    specs: DeviceSpecs,
    controller: Controller,
    input: Reader<RawState>,
    error: Arc<Mutex<Option<String>>>,
    stop: Arc<AtomicBool>,
    reader: Option<JoinHandle<()>>,
}

impl SpaceMouse {
    /// Opens the device at `path` (from [`enumerate`]), or the first one found when `None`.
    pub fn open(path: Option<&str>, settings: SpaceMouseSettings) -> Result<SpaceMouse, DeviceError> {
        let devices = enumerate()?;
        let info = match path {
            Some(p) => devices
                .iter()
                .find(|d| d.path == p)
                .cloned()
                .ok_or_else(|| DeviceError::NotFound(format!("no SpaceMouse at {p}")))?,
            None => devices.first().cloned().ok_or_else(|| {
                DeviceError::NotFound("no SpaceMouse connected (see --list-devices)".into())
            })?,
        };
        let api = hidapi::HidApi::new().map_err(hid_error)?;
        let c_path = std::ffi::CString::new(info.path.clone()).map_err(hid_error)?;
        let device = api.open_path(&c_path).map_err(|e| DeviceError::Io {
            device: info.name.clone(),
            detail: format!("cannot open {}: {e} (check the permissions of the hidraw node)", info.path),
        })?;
        SpaceMouse::from_source(HidSource(device), &info.name, settings)
    }

    /// A SpaceMouse reading from any report source (used by tests with scripted reports).
    pub fn from_source(
        source: impl ReportSource,
        name: &str,
        settings: SpaceMouseSettings,
    ) -> Result<SpaceMouse, DeviceError> {
        let (writer, reader) = triple_buffer::triple_buffer(RawState::default());
        let error = Arc::new(Mutex::new(None));
        let stop = Arc::new(AtomicBool::new(false));
        let thread_error = Arc::clone(&error);
        let thread_stop = Arc::clone(&stop);
        let handle = std::thread::Builder::new()
            .name("spacemouse".into())
            .spawn(move || read_reports(source, writer, &thread_error, &thread_stop))
            .map_err(|e| DeviceError::Io {
                device: name.into(),
                detail: format!("cannot start the reader: {e}"),
            })?;
        let specs = DeviceSpecs {
            name: name.to_string(),
            workspace_radius: settings.workspace_radius,
            max_force: 10.0,
            max_stiffness: 1000.0,
            max_damping: 10.0,
            has_force_output: false,
            has_orientation: true,
            button_count: 32,
        };
        Ok(SpaceMouse {
            specs,
            controller: Controller::new(settings),
            input: reader,
            error,
            stop,
            reader: Some(handle),
        })
    }
}

fn read_reports(
    mut source: impl ReportSource,
    mut writer: Writer<RawState>,
    error: &Mutex<Option<String>>,
    stop: &AtomicBool,
) {
    let mut state = RawState::default();
    let mut buf = [0u8; 64];
    while !stop.load(Ordering::Acquire) {
        match source.read_report(&mut buf, 50) {
            Ok(0) => {}
            Ok(n) => {
                if let Some(report) = decode_report(&buf[..n.min(buf.len())]) {
                    state.apply(report);
                    writer.write(state);
                }
            }
            Err(e) => {
                if let Ok(mut slot) = error.lock() {
                    *slot = Some(e);
                }
                state.failed = true;
                writer.write(state);
                return;
            }
        }
    }
}

impl Drop for SpaceMouse {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Release);
        if let Some(handle) = self.reader.take() {
            let _ = handle.join();
        }
    }
}

impl HapticDevice for SpaceMouse {
    fn specs(&self) -> &DeviceSpecs {
        &self.specs
    }

    fn read(&mut self, time: f64) -> Result<DeviceSample, DeviceError> {
        let raw = self.input.read();
        if raw.failed {
            let detail =
                self.error.lock().ok().and_then(|e| e.clone()).unwrap_or_else(|| "read failed".into());
            return Err(DeviceError::Disconnected { device: self.specs.name.clone(), detail });
        }
        let (position, orientation) = self.controller.update(&raw, time);
        Ok(DeviceSample { position, orientation: Some(orientation), buttons: raw.buttons, timestamp: time })
    }

    fn apply_force(&mut self, force: SafeForce, _time: f64) -> Result<(), DeviceError> {
        self.controller.set_force(force.get());
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::{Duration, Instant};

    #[test]
    fn decodes_the_report_formats() {
        assert_eq!(
            decode_report(&[1, 0x10, 0x00, 0xf0, 0xff, 0x5e, 0x01]),
            Some(Report::Translation([16, -16, 350]))
        );
        assert_eq!(
            decode_report(&[2, 0x00, 0x00, 0xe2, 0xff, 0x00, 0x00]),
            Some(Report::Rotation([0, -30, 0]))
        );
        assert_eq!(
            decode_report(&[1, 1, 0, 2, 0, 3, 0, 4, 0, 5, 0, 0xfa, 0xff]),
            Some(Report::Motion { translation: [1, 2, 3], rotation: [4, 5, -6] })
        );
        assert_eq!(decode_report(&[3, 0x03, 0x00]), Some(Report::Buttons(3)));
        assert_eq!(decode_report(&[3, 0x00, 0x01, 0x00, 0x80]), Some(Report::Buttons(0x8000_0100)));
        assert_eq!(decode_report(&[0x17, 100]), None);
        assert_eq!(decode_report(&[1, 2, 3]), None);
        assert_eq!(decode_report(&[]), None);
    }

    proptest::proptest! {
        #[test]
        fn decoding_never_panics(bytes in proptest::collection::vec(proptest::num::u8::ANY, 0..70)) {
            let _ = decode_report(&bytes);
        }
    }

    #[test]
    fn recognises_the_family() {
        assert!(is_spacemouse(VENDOR_LOGITECH, 0xc626, 1, 8));
        assert!(!is_spacemouse(VENDOR_LOGITECH, 0xc52b, 0, 0), "a Logitech receiver is not a SpaceMouse");
        assert!(is_spacemouse(VENDOR_3DCONNEXION, 0xc6ff, 0, 0), "unknown 3Dconnexion products count");
        assert!(
            !is_spacemouse(VENDOR_3DCONNEXION, 0xc652, 0x0c, 1),
            "not the receiver's consumer-control interface"
        );
    }

    #[test]
    fn position_mode_maps_full_deflection_to_the_workspace() {
        let settings = SpaceMouseSettings { mode: ControlMode::Position, ..SpaceMouseSettings::default() };
        let mut c = Controller::new(settings);
        // Push the cap right: HID +x.
        let raw = RawState { translation: [350, 0, 0], ..RawState::default() };
        let (p, _) = c.update(&raw, 0.0);
        assert!((p - DVec3::new(settings.workspace_radius, 0.0, 0.0)).length() < 1e-12);
        // Press down (HID +z) moves the device down (-y); pull towards you (HID +y) moves +z.
        let raw = RawState { translation: [0, 100, 100], ..RawState::default() };
        let (p, _) = c.update(&raw, 0.0);
        assert!(p.y < 0.0 && p.z > 0.0);
        // Inside the deadband nothing moves.
        let raw = RawState { translation: [5, -5, 3], ..RawState::default() };
        assert_eq!(c.update(&raw, 0.0).0, DVec3::ZERO);
    }

    #[test]
    fn the_cap_follows_the_camera() {
        // The Cornell box's camera: world = (cam.x, cam.y, 3.9 - cam.z), so into the screen is
        // world -z; pushing the cap away (HID -y) must move the cursor to world -z.
        let world_from_camera = DMat3::from_diagonal(DVec3::new(1.0, 1.0, -1.0));
        let settings = SpaceMouseSettings {
            mode: ControlMode::Position,
            device_from_cap: device_from_cap_for_camera(world_from_camera),
            ..SpaceMouseSettings::default()
        };
        let mut c = Controller::new(settings);
        let (p, _) = c.update(&RawState { translation: [0, -350, 0], ..RawState::default() }, 0.0);
        assert!((p - DVec3::new(0.0, 0.0, -settings.workspace_radius)).length() < 1e-12, "{p}");
        // A camera turned 90 degrees about y (looking down world -x... any rotation) keeps
        // right-on-screen as the camera's x axis.
        let turned = DMat3::from_rotation_y(0.5) * DMat3::from_diagonal(DVec3::splat(2.0));
        let m = device_from_cap_for_camera(turned);
        assert!((m * DVec3::X - DMat3::from_rotation_y(0.5) * DVec3::X).length() < 1e-12);
    }

    #[test]
    fn rate_mode_integrates_and_force_feedback_pushes_back() {
        let mut c = Controller::new(SpaceMouseSettings::default());
        let raw = RawState { translation: [350, 0, 0], ..RawState::default() };
        c.update(&raw, 0.0);
        let (p, _) = c.update(&raw, 0.04);
        assert!((p.x - 0.004).abs() < 1e-12, "{p}");
        // Released, with a force pushing back along -x: the goal drifts back.
        c.set_force(DVec3::new(-5.0, 0.0, 0.0));
        let (q, _) = c.update(&RawState::default(), 0.08);
        assert!(q.x < p.x);
        // Never leaves the workspace.
        for i in 0..1000 {
            c.update(&raw, 0.2 + i as f64 * 0.05);
        }
        assert!(c.update(&raw, 100.0).0.length() <= SpaceMouseSettings::default().workspace_radius + 1e-12);
    }

    /// Reports from a script, then an unplug.
    struct Script(Vec<Vec<u8>>);

    impl ReportSource for Script {
        fn read_report(&mut self, buf: &mut [u8], _timeout_ms: i32) -> Result<usize, String> {
            if self.0.is_empty() {
                return Err("No such device (os error 19)".into());
            }
            let r = self.0.remove(0);
            buf[..r.len()].copy_from_slice(&r);
            Ok(r.len())
        }
    }

    #[test]
    fn unplugging_is_an_error_not_a_crash() {
        let script = Script(vec![vec![1, 0x5e, 0x01, 0, 0, 0, 0], vec![3, 1, 0]]);
        let settings = SpaceMouseSettings { mode: ControlMode::Position, ..SpaceMouseSettings::default() };
        let mut dev = SpaceMouse::from_source(script, "scripted", settings).unwrap();
        let deadline = Instant::now() + Duration::from_secs(5);
        let error = loop {
            match dev.read(0.0) {
                Ok(sample) => assert!(sample.position.is_finite()),
                Err(e) => break e,
            }
            assert!(Instant::now() < deadline, "the unplug was never reported");
            std::thread::sleep(Duration::from_millis(1));
        };
        assert!(
            matches!(&error, DeviceError::Disconnected { detail, .. } if detail.contains("os error 19")),
            "{error}"
        );
    }
}
