//! Request dispatch and every request that is not a geometric primitive.

use super::{PResult, ParamContext, PeekKind, Reader, Stop};
use crate::basis::named_basis;
use crate::diagnostics::DiagnosticKind;
use crate::params::{self, ClassCounts};
use crate::scene::{Basis, FileLoc, Handle, MadeTexture, MadeTextureKind, ParamList, ShaderCall};
use crate::target::{RibTarget, ShaderSlot};
use glam::{DMat4, DVec3};

/// Requests of RISpec 3.3 and later renderers that are recognised but have no meaning here;
/// they are skipped with their arguments and one warning each.
const LATER_REQUESTS: &[&str] = &[
    "DisplayChannel",
    "Camera",
    "Shader",
    "PixelSampleImager",
    "EditBegin",
    "EditEnd",
    "EditAttributeBegin",
    "EditAttributeEnd",
    "EditWorldBegin",
    "EditWorldEnd",
    "Integrator",
    "Bxdf",
    "Pattern",
    "Light",
    "LightFilter",
    "SampleFilter",
    "DisplayFilter",
    "VolumeIntegrator",
    "NuCurves",
    "Volume",
    "VPAtmosphere",
    "VPInterior",
    "VPSurface",
    "ProcDelayedReadArchive",
    "ArchiveRecord",
    "CropWindowOffset",
];

impl Reader {
    /// Handles one request whose name token started at `start`.
    pub(crate) fn request<T: RibTarget + ?Sized>(
        &mut self,
        name: &str,
        start: usize,
        t: &mut T,
    ) -> PResult<()> {
        let loc = self.loc(start);
        let r = name;
        if matches!(name, "IfBegin" | "ElseIf" | "Else" | "IfEnd") {
            return self.conditional(name, loc, t);
        }
        if !self.branch_active() {
            // Inside a branch that is not taken: read past the request, build nothing.
            self.skip_arguments();
            return Ok(());
        }
        match name {
            "Resource" => {
                let handle = self.arg_string(r, "the resource handle")?;
                let kind = self.arg_string(r, "the resource type")?;
                let params = self.call_params(r, ("Resource", &kind), &loc)?;
                t.resource(&handle, &kind, params, &mut self.cx(loc));
            }
            "ResourceBegin" => t.resource_begin(&mut self.cx(loc)),
            "ResourceEnd" => t.resource_end(&mut self.cx(loc)),
            // Structure.
            "version" => {
                let v = self.arg_f64(r, "the version number")?;
                t.version(v, &mut self.cx(loc));
            }
            "Declare" => self.declare(&loc, t)?,
            "FrameBegin" => {
                let n = if self.peek(0) == Some(PeekKind::Number) {
                    self.arg_i32(r, "the frame number")?
                } else {
                    0
                };
                self.push_scope(&loc)?;
                t.frame_begin(n, &mut self.cx(loc));
            }
            "FrameEnd" => {
                self.pop_scope();
                t.frame_end(&mut self.cx(loc));
            }
            "WorldBegin" => {
                self.push_scope(&loc)?;
                t.world_begin(&mut self.cx(loc));
            }
            "WorldEnd" => {
                self.pop_scope();
                t.world_end(&mut self.cx(loc));
            }
            "AttributeBegin" => {
                self.push_scope(&loc)?;
                t.attribute_begin(&mut self.cx(loc));
            }
            "AttributeEnd" => {
                self.pop_scope();
                t.attribute_end(&mut self.cx(loc));
            }
            "TransformBegin" => t.transform_begin(&mut self.cx(loc)),
            "TransformEnd" => t.transform_end(&mut self.cx(loc)),
            "SolidBegin" => {
                let op = self.arg_string(r, "the solid operation")?;
                let limit = self.options.limits.max_nesting_depth;
                if self.solid_depth >= limit {
                    self.diagnostics.fatal(
                        DiagnosticKind::Limit,
                        Some(&loc),
                        format!("SolidBegin blocks nested deeper than the limit of {limit}"),
                    );
                    return Err(Stop);
                }
                self.solid_depth += 1;
                t.solid_begin(&op, &mut self.cx(loc));
            }
            "SolidEnd" => {
                self.solid_depth = self.solid_depth.saturating_sub(1);
                t.solid_end(&mut self.cx(loc));
            }
            "ObjectBegin" => {
                let h = self.arg_handle(r)?;
                t.object_begin(h, &mut self.cx(loc));
            }
            "ObjectEnd" => t.object_end(&mut self.cx(loc)),
            "ObjectInstance" => {
                let h = self.arg_handle(r)?;
                t.object_instance(h, &mut self.cx(loc));
            }
            "MotionBegin" => {
                let times = self.arg_float_array(r, "the motion times")?;
                t.motion_begin(&times, &mut self.cx(loc));
            }
            "MotionEnd" => t.motion_end(&mut self.cx(loc)),
            "ReadArchive" => {
                let file = self.arg_string(r, "the archive name")?;
                // RISpec 3.3 allows a parameter list; none is defined that matters here.
                self.param_list(r, ParamContext::Call, None)?;
                self.read_archive(&file, &loc)?;
            }
            "ArchiveBegin" => {
                let archive = self.arg_string(r, "the archive name")?;
                self.param_list(r, ParamContext::Call, None)?;
                self.define_inline_archive(archive, &loc)?;
            }
            "ArchiveEnd" => {
                self.diagnostics.error(DiagnosticKind::Nesting, &loc, "ArchiveEnd without ArchiveBegin");
            }
            "ErrorHandler" => {
                self.arg_string(r, "the handler name")?;
            }

            // Options.
            "Format" => {
                let x = self.arg_i32(r, "the x resolution")?;
                let y = self.arg_i32(r, "the y resolution")?;
                let aspect = self.arg_f64(r, "the pixel aspect ratio")?;
                t.format(x, y, aspect, &mut self.cx(loc));
            }
            "FrameAspectRatio" => {
                let a = self.arg_f64(r, "the frame aspect ratio")?;
                t.frame_aspect_ratio(a, &mut self.cx(loc));
            }
            "ScreenWindow" => {
                let [l, rr, b, tp] = self.arg_f64s::<4>(r, "left right bottom top")?;
                t.screen_window(l, rr, b, tp, &mut self.cx(loc));
            }
            "CropWindow" => {
                let [x0, x1, y0, y1] = self.arg_f64s::<4>(r, "xmin xmax ymin ymax")?;
                t.crop_window(x0, x1, y0, y1, &mut self.cx(loc));
            }
            "Projection" => {
                let name = self.arg_string(r, "the projection name")?;
                self.precise_floats.clear();
                let params = self.call_params(r, ("Projection", &name), &loc)?;
                let fov = self.precise_floats.iter().find(|(n, _)| n == "fov").map(|(_, v)| *v);
                t.projection(&name, params, fov, &mut self.cx(loc));
            }
            "Clipping" => {
                let [near, far] = self.arg_f64s::<2>(r, "near far")?;
                t.clipping(near, far, &mut self.cx(loc));
            }
            "ClippingPlane" => {
                let [x, y, z, nx, ny, nz] = self.arg_f64s::<6>(r, "a point and a normal")?;
                t.clipping_plane(DVec3::new(x, y, z), DVec3::new(nx, ny, nz), &mut self.cx(loc));
            }
            "DepthOfField" => {
                let settings =
                    if self.peek(0) == Some(PeekKind::Number) || self.peek(0) == Some(PeekKind::ArrayBegin) {
                        Some(self.arg_f32s::<3>(r, "fstop focallength focaldistance")?)
                    } else {
                        None
                    };
                t.depth_of_field(settings, &mut self.cx(loc));
            }
            "Shutter" => {
                let [open, close] = self.arg_f32s::<2>(r, "open close")?;
                t.shutter(open, close, &mut self.cx(loc));
            }
            "PixelVariance" => {
                let v = self.arg_f32(r, "the variance")?;
                t.pixel_variance(v, &mut self.cx(loc));
            }
            "PixelSamples" => {
                let [x, y] = self.arg_f32s::<2>(r, "x and y samples")?;
                t.pixel_samples(x, y, &mut self.cx(loc));
            }
            "PixelFilter" => {
                let name = self.arg_string(r, "the filter name")?;
                let [xw, yw] = self.arg_f32s::<2>(r, "the filter widths")?;
                t.pixel_filter(&name, xw, yw, &mut self.cx(loc));
            }
            "Exposure" => {
                let [gain, gamma] = self.arg_f32s::<2>(r, "gain gamma")?;
                t.exposure(gain, gamma, &mut self.cx(loc));
            }
            "Imager" => {
                let call = self.shader_call(r, &loc)?;
                t.imager(call, &mut self.cx(loc));
            }
            "Quantize" => {
                let kind = self.arg_string(r, "the quantize type")?;
                let one = self.arg_i32(r, "one")?;
                let min = self.arg_i32(r, "min")?;
                let max = self.arg_i32(r, "max")?;
                let dither = self.arg_f32(r, "the dither amplitude")?;
                t.quantize(&kind, one, min, max, dither, &mut self.cx(loc));
            }
            "Display" => {
                let name = self.arg_string(r, "the display name")?;
                let driver = self.arg_string(r, "the display type")?;
                let mode = self.arg_string(r, "the display mode")?;
                let params = self.call_params(r, ("Display", &driver), &loc)?;
                t.display(&name, &driver, &mode, params, &mut self.cx(loc));
            }
            "Hider" => {
                let name = self.arg_string(r, "the hider type")?;
                let params = self.call_params(r, ("Hider", &name), &loc)?;
                t.hider(&name, params, &mut self.cx(loc));
            }
            "ColorSamples" => {
                let n_to_rgb = self.arg_float_array(r, "nRGB")?;
                let rgb_to_n = self.arg_float_array(r, "RGBn")?;
                if n_to_rgb.len() != rgb_to_n.len() || n_to_rgb.is_empty() || n_to_rgb.len() % 3 != 0 {
                    self.diagnostics.error(
                        DiagnosticKind::BadArguments,
                        &loc,
                        format!(
                            "ColorSamples: both matrices need 3n values (n colour samples), got {} and {}",
                            n_to_rgb.len(),
                            rgb_to_n.len()
                        ),
                    );
                    return Err(Stop);
                }
                self.scope_mut().color_samples = n_to_rgb.len() / 3;
                t.color_samples(n_to_rgb, rgb_to_n, &mut self.cx(loc));
            }
            "RelativeDetail" => {
                let v = self.arg_f32(r, "the relative detail")?;
                t.relative_detail(v, &mut self.cx(loc));
            }
            "Option" => {
                let namespace = self.arg_string(r, "the option name")?;
                let params = self.call_params(r, ("Option", &namespace), &loc)?;
                if namespace == "searchpath" {
                    for p in &params.0 {
                        if let crate::scene::ParamValues::Strings(v) = &p.values
                            && let Some(value) = v.first()
                        {
                            self.set_search_path(&p.name, value);
                        }
                    }
                }
                t.option(&namespace, params, &mut self.cx(loc));
            }
            "SurfaceIntegrator" => {
                let call = self.shader_call(r, &loc)?;
                t.surface_integrator(call, &mut self.cx(loc));
            }

            // Attributes.
            "Color" | "Opacity" => {
                let n = self.scope().color_samples;
                let nums = self.arg_nums(n, r, "the colour")?;
                let bytes = self.bytes();
                let values: Vec<f32> = nums.iter().map(|x| x.to_f32(&bytes)).collect();
                if name == "Color" {
                    t.color(&values, &mut self.cx(loc));
                } else {
                    t.opacity(&values, &mut self.cx(loc));
                }
            }
            "TextureCoordinates" => {
                let st = self.arg_f32s::<8>(r, "s1 t1 s2 t2 s3 t3 s4 t4")?;
                t.texture_coordinates(st, &mut self.cx(loc));
            }
            "LightSource" | "AreaLightSource" => {
                let shader = self.arg_string(r, "the light shader name")?;
                let handle = self.light_handle(r, &loc)?;
                let params = self.call_params(r, ("LightSource", &shader), &loc)?;
                let call = ShaderCall { name: shader, params, loc: loc.clone() };
                if name == "LightSource" {
                    t.light_source(call, handle, &mut self.cx(loc));
                } else {
                    t.area_light_source(call, handle, &mut self.cx(loc));
                }
            }
            "Illuminate" => {
                let h = self.arg_handle(r)?;
                let on = self.arg_i32(r, "on/off")?;
                t.illuminate(h, on != 0, &mut self.cx(loc));
            }
            "Surface" | "Displacement" | "Atmosphere" | "Interior" | "Exterior" | "Deformation" => {
                let slot = match name {
                    "Surface" => ShaderSlot::Surface,
                    "Displacement" => ShaderSlot::Displacement,
                    "Atmosphere" => ShaderSlot::Atmosphere,
                    "Interior" => ShaderSlot::Interior,
                    "Exterior" => ShaderSlot::Exterior,
                    _ => ShaderSlot::Deformation,
                };
                let call = self.shader_call(r, &loc)?;
                t.shader(slot, call, &mut self.cx(loc));
            }
            "ShadingRate" => {
                let v = self.arg_f32(r, "the shading rate")?;
                t.shading_rate(v, &mut self.cx(loc));
            }
            "ShadingInterpolation" => {
                let kind = self.arg_string(r, "the interpolation type")?;
                t.shading_interpolation(&kind, &mut self.cx(loc));
            }
            "Matte" => {
                let on = self.arg_i32(r, "on/off")?;
                t.matte(on != 0, &mut self.cx(loc));
            }
            "Bound" => {
                let b = self.arg_f32s::<6>(r, "xmin xmax ymin ymax zmin zmax")?;
                t.bound(b, &mut self.cx(loc));
            }
            "Detail" => {
                let b = self.arg_f32s::<6>(r, "xmin xmax ymin ymax zmin zmax")?;
                t.detail(b, &mut self.cx(loc));
            }
            "DetailRange" => {
                let d = self.arg_f32s::<4>(r, "the detail range")?;
                t.detail_range(d, &mut self.cx(loc));
            }
            "GeometricApproximation" => {
                let kind = self.arg_string(r, "the approximation type")?;
                let v = self.arg_f32(r, "the approximation value")?;
                t.geometric_approximation(&kind, v, &mut self.cx(loc));
            }
            "GeometricRepresentation" => {
                let kind = self.arg_string(r, "the representation")?;
                t.geometric_representation(&kind, &mut self.cx(loc));
            }
            "Orientation" => {
                let o = self.arg_string(r, "the orientation")?;
                t.orientation(&o, &mut self.cx(loc));
            }
            "ReverseOrientation" => t.reverse_orientation(&mut self.cx(loc)),
            "Sides" => {
                let s = self.arg_i32(r, "the number of sides")?;
                t.sides(s, &mut self.cx(loc));
            }
            "Attribute" => {
                let namespace = self.arg_string(r, "the attribute name")?;
                let params = self.call_params(r, ("Attribute", &namespace), &loc)?;
                t.attribute(&namespace, params, &mut self.cx(loc));
            }
            "Basis" => {
                let u = self.basis_arg(r, "the u basis")?;
                let u_step = self.arg_i32(r, "the u step")?;
                let v = self.basis_arg(r, "the v basis")?;
                let v_step = self.arg_i32(r, "the v step")?;
                let (Ok(u_step), Ok(v_step)) = (u32::try_from(u_step), u32::try_from(v_step)) else {
                    self.diagnostics.error(DiagnosticKind::BadValue, &loc, "Basis: steps must be positive");
                    return Err(Stop);
                };
                if u_step == 0 || v_step == 0 {
                    self.diagnostics.error(DiagnosticKind::BadValue, &loc, "Basis: steps must be positive");
                    return Err(Stop);
                }
                let s = self.scope_mut();
                s.u_step = u_step;
                s.v_step = v_step;
                t.basis(
                    Basis { matrix: u, step: u_step },
                    Basis { matrix: v, step: v_step },
                    &mut self.cx(loc),
                );
            }
            "TrimCurve" => self.trim_curve(&loc, t)?,

            // Transformations.
            "Identity" => t.identity(&mut self.cx(loc)),
            "Transform" | "ConcatTransform" => {
                let m = self.arg_f64s::<16>(r, "a 4x4 matrix")?;
                let matrix = DMat4::from_cols_array(&m);
                if name == "Transform" {
                    t.transform(matrix, &mut self.cx(loc));
                } else {
                    t.concat_transform(matrix, &mut self.cx(loc));
                }
            }
            "Perspective" => {
                let fov = self.arg_f64(r, "the field of view")?;
                t.perspective(fov, &mut self.cx(loc));
            }
            "Translate" => {
                let [x, y, z] = self.arg_f64s::<3>(r, "dx dy dz")?;
                t.translate(DVec3::new(x, y, z), &mut self.cx(loc));
            }
            "Rotate" => {
                let [a, x, y, z] = self.arg_f64s::<4>(r, "angle dx dy dz")?;
                t.rotate(a, DVec3::new(x, y, z), &mut self.cx(loc));
            }
            "Scale" => {
                let [x, y, z] = self.arg_f64s::<3>(r, "sx sy sz")?;
                t.scale(DVec3::new(x, y, z), &mut self.cx(loc));
            }
            "Skew" => {
                let [a, x1, y1, z1, x2, y2, z2] = self.arg_f64s::<7>(r, "angle dx1 dy1 dz1 dx2 dy2 dz2")?;
                t.skew(a, DVec3::new(x1, y1, z1), DVec3::new(x2, y2, z2), &mut self.cx(loc));
            }
            "CoordinateSystem" => {
                let n = self.arg_string(r, "the coordinate system name")?;
                t.coordinate_system(&n, &mut self.cx(loc));
            }
            "ScopedCoordinateSystem" => {
                let n = self.arg_string(r, "the coordinate system name")?;
                t.scoped_coordinate_system(&n, &mut self.cx(loc));
            }
            "CoordSysTransform" => {
                let n = self.arg_string(r, "the coordinate system name")?;
                t.coord_sys_transform(&n, &mut self.cx(loc));
            }

            // Geometry.
            "Polygon"
            | "GeneralPolygon"
            | "PointsPolygons"
            | "PointsGeneralPolygons"
            | "Patch"
            | "PatchMesh"
            | "NuPatch"
            | "SubdivisionMesh"
            | "HierarchicalSubdivisionMesh"
            | "Sphere"
            | "Cone"
            | "Cylinder"
            | "Hyperboloid"
            | "Paraboloid"
            | "Disk"
            | "Torus"
            | "Points"
            | "Curves"
            | "Blobby"
            | "Procedural"
            | "Geometry" => {
                self.geometry(name, &loc, t)?;
            }

            // Textures are never made here: the request is kept, so a renderer can read the
            // pictures themselves.
            "MakeTexture" => {
                let picture = self.arg_string(r, "the picture name")?;
                let name = self.arg_string(r, "the texture name")?;
                let swrap = self.arg_string(r, "the s wrap mode")?;
                let twrap = self.arg_string(r, "the t wrap mode")?;
                let filter = self.arg_string(r, "the filter name")?;
                let [sw, tw] = self.arg_f32s::<2>(r, "the filter widths")?;
                let params = self.param_list(r, ParamContext::Call, None)?;
                let kind = MadeTextureKind::Texture { picture, swrap, twrap };
                let made =
                    MadeTexture { name, kind, filter, filter_width: (sw, tw), params, loc: loc.clone() };
                t.made_texture(made, &mut self.cx(loc));
            }
            "MakeLatLongEnvironment" => {
                let picture = self.arg_string(r, "the picture name")?;
                let name = self.arg_string(r, "the texture name")?;
                let filter = self.arg_string(r, "the filter name")?;
                let [sw, tw] = self.arg_f32s::<2>(r, "the filter widths")?;
                let params = self.param_list(r, ParamContext::Call, None)?;
                let kind = MadeTextureKind::LatLong { picture };
                let made =
                    MadeTexture { name, kind, filter, filter_width: (sw, tw), params, loc: loc.clone() };
                t.made_texture(made, &mut self.cx(loc));
            }
            "MakeCubeFaceEnvironment" => {
                let mut faces: [String; 6] = Default::default();
                for (face, what) in faces.iter_mut().zip(["+x", "-x", "+y", "-y", "+z", "-z"]) {
                    *face = self.arg_string(r, &format!("the {what} picture"))?;
                }
                let name = self.arg_string(r, "the texture name")?;
                let fov = self.arg_f32(r, "the field of view")?;
                let filter = self.arg_string(r, "the filter name")?;
                let [sw, tw] = self.arg_f32s::<2>(r, "the filter widths")?;
                let params = self.param_list(r, ParamContext::Call, None)?;
                let kind = MadeTextureKind::CubeFaces { faces, fov };
                let made =
                    MadeTexture { name, kind, filter, filter_width: (sw, tw), params, loc: loc.clone() };
                t.made_texture(made, &mut self.cx(loc));
            }
            "MakeBump" | "MakeBrickMap" | "MakeOcclusion" => {
                self.skip_arguments();
                t.make_texture(name, &mut self.cx(loc));
            }

            "MakeShadow" => {
                self.skip_arguments();
                t.make_shadow(&mut self.cx(loc));
            }

            // Never executed.
            "System" => {
                self.skip_arguments();
                self.diagnostics.warn(
                    DiagnosticKind::Refused,
                    &loc,
                    "System would run a shell command; refused (scenes never execute programs)",
                );
            }
            // RenderMan 3.3's shader networks: every layer is a shader program.
            "ShaderLayer" | "ConnectShaderLayers" => {
                let kind = self.arg_string(r, "the shader type")?;
                let what = if name == "ShaderLayer" {
                    let shader = self.arg_string(r, "the shader name")?;
                    format!("ShaderLayer \"{kind}\" \"{shader}\"")
                } else {
                    format!("ConnectShaderLayers \"{kind}\"")
                };
                self.diagnostics.warn(
                    DiagnosticKind::Unsupported,
                    &loc,
                    format!("{what}: shader networks connect shaders written in the RenderMan Shading Language, which a renderer without an RSL compiler cannot evaluate; skipped with its arguments"),
                );
                self.skip_arguments();
            }
            _ if LATER_REQUESTS.contains(&name) => {
                self.diagnostics.warn(
                    DiagnosticKind::UnknownRequest,
                    &loc,
                    format!("'{name}' (a request of later RenderMan versions) is not supported; skipped with its arguments"),
                );
                self.skip_arguments();
            }
            _ => {
                self.diagnostics.warn(
                    DiagnosticKind::UnknownRequest,
                    &loc,
                    format!("unknown request '{name}'; skipped with its arguments"),
                );
                self.skip_arguments();
            }
        }
        Ok(())
    }

    /// Skips every token up to the next request (the arguments of a skipped request).
    fn skip_arguments(&mut self) {
        self.skip_to_request();
    }

    fn declare<T: RibTarget + ?Sized>(&mut self, loc: &FileLoc, t: &mut T) -> PResult<()> {
        let name = self.arg_string("Declare", "the parameter name")?;
        // Some writers emit `Declare "name"` with no type: nothing to declare.
        if self.peek(0) != Some(PeekKind::String) {
            self.diagnostics.warn(
                DiagnosticKind::BadDeclaration,
                loc,
                format!("Declare \"{name}\" has no type; ignored"),
            );
            return Ok(());
        }
        let text = self.arg_string("Declare", "the declaration")?;
        match params::parse_decl(&text) {
            Ok(decl) => {
                self.decls.declare(&name, decl);
                t.declare(&name, decl, &mut self.cx(loc.clone()));
                Ok(())
            }
            Err(e) => {
                self.diagnostics.error(
                    DiagnosticKind::BadDeclaration,
                    loc,
                    format!("Declare \"{name}\" \"{text}\": {e}"),
                );
                Err(Stop)
            }
        }
    }

    /// A parameter list of a non-geometry call, every parameter one element long.
    fn call_params(&mut self, request: &str, namespace: (&str, &str), _loc: &FileLoc) -> PResult<ParamList> {
        let params = self.param_list(request, ParamContext::Call, Some(namespace))?;
        self.check_counts(request, &params, &ClassCounts::SINGLE)?;
        Ok(params)
    }

    /// `"shadername" params`.
    fn shader_call(&mut self, request: &str, loc: &FileLoc) -> PResult<ShaderCall> {
        let name = self.arg_string(request, "the shader name")?;
        let params = self.call_params(request, (request, &name), loc)?;
        Ok(ShaderCall { name, params, loc: loc.clone() })
    }

    /// The handle of `LightSource name handle params`: a number or a string. A string followed
    /// by a value is a parameter name (the handle is missing, as in some old writers).
    fn light_handle(&mut self, request: &str, loc: &FileLoc) -> PResult<Handle> {
        match self.peek(0) {
            Some(PeekKind::Number) => Ok(Handle::Int(self.arg_i32(request, "the light handle")?)),
            Some(PeekKind::String)
                if matches!(self.peek(1), Some(PeekKind::String | PeekKind::Request | PeekKind::Eof)) =>
            {
                Ok(Handle::Name(self.arg_string(request, "the light handle")?))
            }
            _ => {
                self.unnamed_handles += 1;
                let h = format!("<unnamed light {}>", self.unnamed_handles);
                self.warn_once(
                    "light-without-handle",
                    loc,
                    DiagnosticKind::BadArguments,
                    format!("{request} without a handle; it can only be referred to as \"{h}\""),
                );
                Ok(Handle::Name(h))
            }
        }
    }

    /// A basis: a standard name or 16 numbers.
    fn basis_arg(&mut self, request: &str, what: &str) -> PResult<[f32; 16]> {
        if self.peek(0) == Some(PeekKind::String) {
            let start = self.peek_start();
            let name = self.arg_string(request, what)?;
            return match named_basis(&name) {
                Some(b) => Ok(b.matrix),
                None => {
                    let loc = self.loc(start);
                    self.diagnostics.error(
                        DiagnosticKind::BadValue,
                        &loc,
                        format!("{request}: unknown basis \"{name}\" (expected bezier, b-spline, catmull-rom, hermite or power)"),
                    );
                    Err(Stop)
                }
            };
        }
        self.arg_f32s::<16>(request, what)
    }
}
