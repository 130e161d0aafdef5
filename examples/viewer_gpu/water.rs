//! Screen-space water on the GPU, as a kiss3d post-processing effect.
//!
//! kiss3d 0.47 hands a [`PostProcessingEffect`] the frame's command encoder, the scene's
//! tonemapped colour (an offscreen texture) and the view to write. It does not hand it the
//! scene's depth: the `depth_view` of the render target it passes belongs to that
//! post-processing target, not to the HDR film the meshes were drawn into, and a
//! [`kiss3d::renderer::Renderer3d`] (which does draw with the scene's depth attached) gets a
//! single render pass on the scene's colour and depth, with no way to attach textures of its
//! own. So the effect draws the colliders' depth itself (their triangles, posed on the CPU,
//! a few thousand at most) and runs every fluid pass on textures it owns:
//!
//! 1. colliders' depth (a depth-only pass);
//! 2. thickness: each particle's ellipsoid (Yu & Turk 2013, from
//!    `rapier_sph::visual::Anisotropy`) as a camera-facing quad whose fragments intersect
//!    the ray with the ellipsoid; the chord is summed by additive blending (R16Float);
//! 3. foam, spray and bubbles (`rapier_sph::render::WorldDiffuse`) as soft dots, summed;
//! 4. depth: the nearest intersection, written as view depth (R32Float) and as the
//!    fragment's depth (tested against the colliders);
//! 5. the narrow-range filter (Truong & Yuksel 2018), separable, x then y;
//! 6. composite over the scene's colour: normals from the smoothed depth, Fresnel between a
//!    sky reflection and the refracted scene behind (shifted by the normal and the
//!    thickness, Beer–Lambert absorbed), a sun highlight, foam on top.
//!
//! The shading constants are those of the CPU path (`src/render/ssf.rs`).

use kiss3d::context::Context;
use kiss3d::glamx::glam::camera::rh::proj::directx;
use kiss3d::glamx::{Mat4, Vec3};
use kiss3d::post_processing::{PostProcessingContext, PostProcessingEffect};
use kiss3d::resource::RenderTarget;

/// Bytes of a slice of `f32`s (native endianness, as the GPU reads them).
fn bytes(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|x| x.to_ne_bytes()).collect()
}

/// One particle's splat: center and bounding radius, then the rows `axes[k] / radii[k]` of
/// the inverse map (world space); the first row's `w` is the foam weight of a foam dot.
pub type Splat = [f32; 16];

/// What the example sets each frame.
pub struct View {
    /// World → view.
    pub view: Mat4,
    /// Vertical field of view (radians) and clip planes, as kiss3d's camera has them.
    pub fov: f32,
    pub znear: f32,
    pub zfar: f32,
    /// Direction to the sun (world).
    pub light: Vec3,
    /// The fluid's particle spacing (m).
    pub spacing: f32,
}

/// A vertex or instance buffer that grows as needed.
struct Buffer {
    buf: Option<wgpu::Buffer>,
    capacity: u64,
    count: u32,
}

impl Buffer {
    fn new() -> Self {
        Self {
            buf: None,
            capacity: 0,
            count: 0,
        }
    }

    fn upload(&mut self, ctxt: &Context, data: &[f32], stride: usize, usage: wgpu::BufferUsages) {
        self.count = (data.len() / stride) as u32;
        let size = (data.len() * 4) as u64;
        if size == 0 {
            return;
        }
        if self.buf.is_none() || size > self.capacity {
            self.capacity = size.next_power_of_two();
            self.buf = Some(ctxt.create_buffer_simple(
                Some("water buffer"),
                self.capacity,
                usage | wgpu::BufferUsages::COPY_DST,
            ));
        }
        ctxt.write_buffer(self.buf.as_ref().unwrap(), 0, &bytes(data));
    }

    fn slice(&self) -> Option<wgpu::BufferSlice<'_>> {
        match &self.buf {
            Some(b) if self.count > 0 => Some(b.slice(..)),
            _ => None,
        }
    }
}

/// The textures the passes own, sized to the window.
struct Targets {
    size: (u32, u32),
    colliders: wgpu::TextureView,
    raw: wgpu::TextureView,
    tmp: wgpu::TextureView,
    smooth: wgpu::TextureView,
    thickness: wgpu::TextureView,
    foam: wgpu::TextureView,
    smooth_x: wgpu::BindGroup,
    smooth_y: wgpu::BindGroup,
}

fn texture(ctxt: &Context, (w, h): (u32, u32), format: wgpu::TextureFormat) -> wgpu::TextureView {
    ctxt.create_texture(&wgpu::TextureDescriptor {
        label: Some("water texture"),
        size: wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
        view_formats: &[],
    })
    .create_view(&wgpu::TextureViewDescriptor::default())
}

fn textures_group(
    ctxt: &Context,
    layout: &wgpu::BindGroupLayout,
    views: [&wgpu::TextureView; 4],
) -> wgpu::BindGroup {
    let entries: Vec<wgpu::BindGroupEntry> = views
        .iter()
        .enumerate()
        .map(|(i, v)| wgpu::BindGroupEntry {
            binding: i as u32,
            resource: wgpu::BindingResource::TextureView(v),
        })
        .collect();
    ctxt.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("water textures"),
        layout,
        entries: &entries,
    })
}

struct Pipelines {
    colliders: wgpu::RenderPipeline,
    thickness: wgpu::RenderPipeline,
    foam: wgpu::RenderPipeline,
    depth: wgpu::RenderPipeline,
    smooth_x: wgpu::RenderPipeline,
    smooth_y: wgpu::RenderPipeline,
    composite: wgpu::RenderPipeline,
}

const R32: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;
const R16: wgpu::TextureFormat = wgpu::TextureFormat::R16Float;
const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// A pipeline description: entry points, target (format, additive?), depth (compare, write).
struct Pass<'a> {
    vs: &'a str,
    fs: Option<&'a str>,
    target: Option<(wgpu::TextureFormat, bool)>,
    depth: Option<(wgpu::CompareFunction, bool)>,
    buffers: &'a [Option<wgpu::VertexBufferLayout<'a>>],
}

fn pipeline(
    ctxt: &Context,
    module: &wgpu::ShaderModule,
    layout: &wgpu::PipelineLayout,
    p: Pass,
) -> wgpu::RenderPipeline {
    let add = wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::One,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    };
    let targets: Vec<Option<wgpu::ColorTargetState>> = p
        .target
        .map(|(format, additive)| wgpu::ColorTargetState {
            format,
            blend: additive.then_some(wgpu::BlendState {
                color: add,
                alpha: add,
            }),
            write_mask: wgpu::ColorWrites::ALL,
        })
        .into_iter()
        .map(Some)
        .collect();
    ctxt.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(p.vs),
        layout: Some(layout),
        vertex: wgpu::VertexState {
            module,
            entry_point: Some(p.vs),
            buffers: p.buffers,
            compilation_options: Default::default(),
        },
        fragment: p.fs.map(|fs| wgpu::FragmentState {
            module,
            entry_point: Some(fs),
            targets: &targets,
            compilation_options: Default::default(),
        }),
        primitive: wgpu::PrimitiveState::default(),
        depth_stencil: p.depth.map(|(compare, write)| wgpu::DepthStencilState {
            format: DEPTH,
            depth_write_enabled: Some(write),
            depth_compare: Some(compare),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: wgpu::MultisampleState::default(),
        multiview_mask: None,
        cache: None,
    })
}

const SPLAT_ATTRS: [wgpu::VertexAttribute; 4] = wgpu::vertex_attr_array![
    0 => Float32x4, 1 => Float32x4, 2 => Float32x4, 3 => Float32x4
];
const POINT_ATTRS: [wgpu::VertexAttribute; 1] = wgpu::vertex_attr_array![0 => Float32x3];

fn pipelines(
    ctxt: &Context,
    frame_layout: &wgpu::BindGroupLayout,
    tex_layout: &wgpu::BindGroupLayout,
) -> Pipelines {
    let module = ctxt.create_shader_module(Some("water"), include_str!("water.wgsl"));
    let geo = ctxt.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("water geometry"),
        bind_group_layouts: &[Some(frame_layout)],
        immediate_size: 0,
    });
    let full = ctxt.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("water full screen"),
        bind_group_layouts: &[Some(frame_layout), Some(tex_layout)],
        immediate_size: 0,
    });
    let splat = [Some(wgpu::VertexBufferLayout {
        array_stride: 64,
        step_mode: wgpu::VertexStepMode::Instance,
        attributes: &SPLAT_ATTRS,
    })];
    let point = [Some(wgpu::VertexBufferLayout {
        array_stride: 12,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &POINT_ATTRS,
    })];
    use wgpu::CompareFunction::{Less, LessEqual};
    let geo_pass = |vs, fs, target, depth, buffers| {
        let p = Pass {
            vs,
            fs,
            target,
            depth,
            buffers,
        };
        pipeline(ctxt, &module, &geo, p)
    };
    let full_pass = |fs, format| {
        let p = Pass {
            vs: "vs_full",
            fs: Some(fs),
            target: Some((format, false)),
            depth: None,
            buffers: &[],
        };
        pipeline(ctxt, &module, &full, p)
    };
    Pipelines {
        colliders: geo_pass("vs_collider", None, None, Some((Less, true)), &point),
        thickness: geo_pass(
            "vs_splat",
            Some("fs_thickness"),
            Some((R16, true)),
            Some((LessEqual, false)),
            &splat,
        ),
        foam: geo_pass(
            "vs_splat",
            Some("fs_foam"),
            Some((R16, true)),
            Some((LessEqual, false)),
            &splat,
        ),
        depth: geo_pass(
            "vs_splat",
            Some("fs_depth"),
            Some((R32, false)),
            Some((Less, true)),
            &splat,
        ),
        smooth_x: full_pass("fs_smooth_x", R32),
        smooth_y: full_pass("fs_smooth_y", R32),
        composite: full_pass("fs_composite", ctxt.surface_format),
    }
}

fn layouts(ctxt: &Context) -> (wgpu::BindGroupLayout, wgpu::BindGroupLayout) {
    let frame = ctxt.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("water frame"),
        entries: &[wgpu::BindGroupLayoutEntry {
            binding: 0,
            visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        }],
    });
    let tex = |binding| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: false },
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        count: None,
    };
    let textures = ctxt.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("water textures"),
        entries: &[tex(0), tex(1), tex(2), tex(3)],
    });
    (frame, textures)
}

/// The effect: set [`Self::view`], upload splats and colliders, then hand it to
/// `Window::render_3d_with_chain`.
pub struct GpuWater {
    pub view: View,
    /// Footprint half-width of the depth filter in spacings (the CPU path's 2.5) and its
    /// cap in pixels.
    pub filter_spacings: f32,
    pub filter_max_px: f32,
    /// Times the passes run per frame (1; more only to time them: the frame time grows by
    /// their cost per extra run).
    pub repeat: usize,
    pipelines: Pipelines,
    tex_layout: wgpu::BindGroupLayout,
    uniform: wgpu::Buffer,
    frame_group: wgpu::BindGroup,
    targets: Option<Targets>,
    splats: Buffer,
    foam: Buffer,
    colliders: Buffer,
}

impl GpuWater {
    pub fn new(view: View) -> Self {
        let ctxt = Context::get();
        let (frame_layout, tex_layout) = layouts(&ctxt);
        let pipelines = pipelines(&ctxt, &frame_layout, &tex_layout);
        let uniform = ctxt.create_buffer_simple(
            Some("water frame"),
            56 * 4,
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
        );
        let frame_group = ctxt.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("water frame"),
            layout: &frame_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: uniform.as_entire_binding(),
            }],
        });
        Self {
            view,
            filter_spacings: 2.5,
            filter_max_px: 24.0,
            repeat: 1,
            pipelines,
            tex_layout,
            uniform,
            frame_group,
            targets: None,
            splats: Buffer::new(),
            foam: Buffer::new(),
            colliders: Buffer::new(),
        }
    }

    /// The particles' ellipsoids.
    pub fn set_splats(&mut self, splats: &[Splat]) {
        let ctxt = Context::get();
        self.splats
            .upload(&ctxt, splats.as_flattened(), 16, wgpu::BufferUsages::VERTEX);
    }

    /// Foam, spray and bubble dots (spheres; the first row's `w` is the dot's weight).
    pub fn set_foam(&mut self, dots: &[Splat]) {
        let ctxt = Context::get();
        self.foam
            .upload(&ctxt, dots.as_flattened(), 16, wgpu::BufferUsages::VERTEX);
    }

    /// The triangles (world space, three points each) that hide the water behind them.
    pub fn set_colliders(&mut self, points: &[[f32; 3]]) {
        let ctxt = Context::get();
        self.colliders
            .upload(&ctxt, points.as_flattened(), 3, wgpu::BufferUsages::VERTEX);
    }

    fn ensure_targets(&mut self, ctxt: &Context, size: (u32, u32)) {
        if self.targets.as_ref().is_some_and(|t| t.size == size) {
            return;
        }
        let raw = texture(ctxt, size, R32);
        let tmp = texture(ctxt, size, R32);
        let smooth_x = textures_group(ctxt, &self.tex_layout, [&raw, &raw, &raw, &raw]);
        let smooth_y = textures_group(ctxt, &self.tex_layout, [&tmp, &tmp, &tmp, &tmp]);
        self.targets = Some(Targets {
            size,
            colliders: texture(ctxt, size, DEPTH),
            raw,
            tmp,
            smooth: texture(ctxt, size, R32),
            thickness: texture(ctxt, size, R16),
            foam: texture(ctxt, size, R16),
            smooth_x,
            smooth_y,
        });
    }

    /// The frame's uniforms (layout of `Frame` in water.wgsl).
    fn write_frame(&self, ctxt: &Context, (w, h): (u32, u32)) {
        let v = &self.view;
        let aspect = w as f32 / h.max(1) as f32;
        let proj = directx::perspective(v.fov, aspect, v.znear, v.zfar);
        let focal = 0.5 * h as f32 / (0.5 * v.fov).tan();
        let light = v.view.transform_vector3(v.light.normalize());
        let up = v.view.transform_vector3(Vec3::Y);
        let mut data = Vec::with_capacity(56);
        data.extend_from_slice(&v.view.to_cols_array());
        data.extend_from_slice(&proj.to_cols_array());
        data.extend_from_slice(&[w as f32, h as f32, focal, 0.0]);
        data.extend_from_slice(&[
            self.filter_spacings * v.spacing,
            v.spacing,
            self.filter_max_px,
            0.0,
        ]);
        data.extend_from_slice(&[light.x, light.y, light.z, 0.0]);
        data.extend_from_slice(&[up.x, up.y, up.z, 0.0]);
        // Absorption per spacing (R, G, B) and the refraction strength, deep colour and
        // spacing: the CPU path's defaults (`RenderOptions::default()`).
        data.extend_from_slice(&[0.6, 0.22, 0.11, 0.25]);
        data.extend_from_slice(&[0.01, 0.09, 0.26, v.spacing]);
        ctxt.write_buffer(&self.uniform, 0, &bytes(&data));
    }
}

/// A render pass on `color` (cleared to `clear`) and optionally `depth` (cleared when
/// `clear_depth`).
fn begin<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    color: Option<(&wgpu::TextureView, f64)>,
    depth: Option<(&wgpu::TextureView, bool)>,
) -> wgpu::RenderPass<'e> {
    let color_attachments: Vec<Option<wgpu::RenderPassColorAttachment>> = color
        .map(|(view, clear)| wgpu::RenderPassColorAttachment {
            view,
            resolve_target: None,
            ops: wgpu::Operations {
                load: wgpu::LoadOp::Clear(wgpu::Color {
                    r: clear,
                    g: clear,
                    b: clear,
                    a: 1.0,
                }),
                store: wgpu::StoreOp::Store,
            },
            depth_slice: None,
        })
        .into_iter()
        .map(Some)
        .collect();
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some("water pass"),
        color_attachments: &color_attachments,
        depth_stencil_attachment: depth.map(|(view, clear)| {
            wgpu::RenderPassDepthStencilAttachment {
                view,
                depth_ops: Some(wgpu::Operations {
                    load: if clear {
                        wgpu::LoadOp::Clear(1.0)
                    } else {
                        wgpu::LoadOp::Load
                    },
                    store: wgpu::StoreOp::Store,
                }),
                stencil_ops: None,
            }
        }),
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

impl GpuWater {
    /// Passes 1–4: colliders' depth, thickness, foam, fluid depth.
    fn geometry(&self, encoder: &mut wgpu::CommandEncoder, t: &Targets) {
        let p = &self.pipelines;
        {
            let mut pass = begin(encoder, None, Some((&t.colliders, true)));
            if let Some(s) = self.colliders.slice() {
                pass.set_pipeline(&p.colliders);
                pass.set_bind_group(0, &self.frame_group, &[]);
                pass.set_vertex_buffer(0, s);
                pass.draw(0..self.colliders.count, 0..1);
            }
        }
        let splat_passes = [
            (&p.thickness, &t.thickness, 0.0, &self.splats),
            (&p.foam, &t.foam, 0.0, &self.foam),
            (&p.depth, &t.raw, 1.0e30, &self.splats),
        ];
        for (pipe, view, clear, buf) in splat_passes {
            let mut pass = begin(encoder, Some((view, clear)), Some((&t.colliders, false)));
            if let Some(s) = buf.slice() {
                pass.set_pipeline(pipe);
                pass.set_bind_group(0, &self.frame_group, &[]);
                pass.set_vertex_buffer(0, s);
                pass.draw(0..6, 0..buf.count);
            }
        }
    }

    /// Passes 5–6: the depth filter, the composite into `out`.
    fn screen(
        &self,
        ctxt: &Context,
        encoder: &mut wgpu::CommandEncoder,
        t: &Targets,
        (scene, out): (&wgpu::TextureView, &wgpu::TextureView),
    ) {
        let p = &self.pipelines;
        let composite = textures_group(
            ctxt,
            &self.tex_layout,
            [scene, &t.smooth, &t.thickness, &t.foam],
        );
        let passes = [
            (&p.smooth_x, &t.tmp, &t.smooth_x),
            (&p.smooth_y, &t.smooth, &t.smooth_y),
            (&p.composite, out, &composite),
        ];
        for (pipe, view, group) in passes {
            let mut pass = begin(encoder, Some((view, 0.0)), None);
            pass.set_pipeline(pipe);
            pass.set_bind_group(0, &self.frame_group, &[]);
            pass.set_bind_group(1, group, &[]);
            pass.draw(0..3, 0..1);
        }
    }
}

impl PostProcessingEffect for GpuWater {
    fn update(&mut self, _dt: f32, _w: f32, _h: f32, _znear: f32, _zfar: f32) {}

    fn draw(&mut self, target: &RenderTarget, context: &mut PostProcessingContext) {
        let RenderTarget::Offscreen(o) = target else {
            return;
        };
        let ctxt = Context::get();
        let size = (o.width.max(1), o.height.max(1));
        self.ensure_targets(&ctxt, size);
        self.write_frame(&ctxt, size);
        let t = self.targets.as_ref().expect("just sized");
        for _ in 0..self.repeat.max(1) {
            self.geometry(context.encoder, t);
            self.screen(
                &ctxt,
                context.encoder,
                t,
                (&o.color_view, context.output_view),
            );
        }
    }
}
