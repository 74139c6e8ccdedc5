//! The device: an adapter, the kernels' precision (f64 where it has `SHADER_F64`,
//! f32 otherwise or by choice: `precision.rs`), its pipelines, and buffer plumbing.

use crate::masks::EffectMasks;
use crate::precision::Precision;
use crate::shaders::module_source_at;
use crate::sums::SumsVariant;
use crate::timing::{KernelTime, Timer};
use crate::{GpuError, Result};
use std::collections::HashMap;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use wgpu::util::DeviceExt;

/// A GPU ready to run the bpins kernels.
pub struct Gpu {
    pub(crate) device: wgpu::Device,
    pub(crate) queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    pub(crate) precision: Precision,
    pub(crate) limits: wgpu::Limits,
    pub(crate) pipelines: Pipelines,
    /// Errors wgpu reports outside an error scope (kept, never a panic).
    uncaptured: Arc<Mutex<Vec<String>>>,
    /// Bytes written to the device and read back since the last [`Gpu::take_traffic`].
    uploaded: AtomicU64,
    downloaded: AtomicU64,
    /// Per-kernel timestamps, where the adapter has them.
    timer: Option<Timer>,
}

/// Host ↔ device traffic: bytes uploaded (parameters, inputs) and downloaded (results).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Traffic {
    pub uploaded_bytes: u64,
    pub downloaded_bytes: u64,
}

pub(crate) struct Pipelines {
    render_module: wgpu::ShaderModule,
    sums_module: wgpu::ShaderModule,
    /// The pipelines of `render.wgsl` and `sums.wgsl`, one per entry point and set of
    /// pipeline constants (the dispatch's effect masks, `SumsVariant`), each made on
    /// first use (llvmpipe compiles each for a while).
    specialised: Mutex<HashMap<Specialisation, wgpu::ComputePipeline>>,
    pub reduce_partials: wgpu::ComputePipeline,
    /// `reduce_partials_serial`: the same sums without barriers, for a CPU adapter.
    pub reduce_partials_serial: wgpu::ComputePipeline,
}

/// One specialised pipeline: its entry point and its constants (name, value's bits).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
struct Specialisation {
    entry: &'static str,
    constants: Vec<(&'static str, u64)>,
}

/// An entry point of `render.wgsl`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum RenderEntry {
    Mosaic,
    ColourMosaic,
    Colocated,
    ChainMaps,
    SkyMaps,
}

impl RenderEntry {
    fn name(self) -> &'static str {
        match self {
            RenderEntry::Mosaic => "render_mosaic",
            RenderEntry::ColourMosaic => "render_colour_mosaic",
            RenderEntry::Colocated => "render_colocated",
            RenderEntry::ChainMaps => "chain_maps",
            RenderEntry::SkyMaps => "sky_maps",
        }
    }
}

impl Gpu {
    /// Opens the best adapter ([`open_adapter`]: Vulkan, Metal or DX12, then GL; a
    /// discrete GPU before an integrated one before a CPU rasterizer), with the f64
    /// kernels where it has f64 shaders and the f32 ones where it has not. Errors,
    /// never panics, when there is none.
    pub fn new() -> Result<Gpu> {
        Gpu::with_precision(None)
    }

    /// [`Gpu::new`] at a chosen precision (`None`: f64 where the adapter has it); f64
    /// on an adapter without f64 shaders is an error naming the adapter.
    pub fn with_precision(precision: Option<Precision>) -> Result<Gpu> {
        Gpu::open(precision, None)
    }

    /// [`Gpu::with_precision`] on the given wgpu backends only (`None`: as
    /// [`Gpu::new`] chooses), e.g. `wgpu::Backends::GL` for wgpu's GL backend.
    pub fn open(precision: Option<Precision>, backends: Option<wgpu::Backends>) -> Result<Gpu> {
        let adapter = open_adapter(backends)?;
        let info = adapter.get_info();
        let has_f64 = adapter.features().contains(wgpu::Features::SHADER_F64);
        let precision = match precision {
            Some(Precision::F64) if !has_f64 => {
                return Err(GpuError::MissingFeature {
                    adapter: info.name.clone(),
                    feature: "SHADER_F64 (f64 in shaders; --gpu-precision f32 runs without it)",
                })
            }
            Some(p) => p,
            None if has_f64 => Precision::F64,
            None => Precision::F32,
        };
        let timestamps = adapter.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let required_features = match precision {
            Precision::F64 => wgpu::Features::SHADER_F64,
            Precision::F32 => wgpu::Features::empty(),
        } | if timestamps { wgpu::Features::TIMESTAMP_QUERY } else { wgpu::Features::empty() };
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("bpins"),
            required_features,
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| GpuError::Device(e.to_string()))?;
        let uncaptured = Arc::new(Mutex::new(Vec::new()));
        let sink = uncaptured.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut v) = sink.lock() {
                v.push(e.to_string());
            }
        }));
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let pipelines = Pipelines::new(&device, precision)?;
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Shader(e.to_string()));
        }
        Ok(Gpu {
            device,
            info,
            precision,
            limits,
            pipelines,
            uncaptured,
            uploaded: AtomicU64::new(0),
            downloaded: AtomicU64::new(0),
            timer: timestamps.then(|| Timer::new(&queue)),
            queue,
        })
    }

    /// The adapter, as "name (driver, backend)".
    pub fn adapter_name(&self) -> String {
        let i = &self.info;
        let driver =
            if i.driver_info.is_empty() { i.driver.clone() } else { format!("{} {}", i.driver, i.driver_info) };
        format!("{} ({}, {:?})", i.name, driver, i.backend)
    }

    /// The precision the kernels run at.
    pub fn precision(&self) -> Precision {
        self.precision
    }

    /// The traffic since the last call (or since the device opened), then zero again.
    pub fn take_traffic(&self) -> Traffic {
        Traffic {
            uploaded_bytes: self.uploaded.swap(0, Ordering::Relaxed),
            downloaded_bytes: self.downloaded.swap(0, Ordering::Relaxed),
        }
    }

    /// Device time per kernel since the last call (or since the device opened), then
    /// zero again; `None` where the adapter has no timestamp queries.
    pub fn take_kernel_times(&self) -> Option<Vec<KernelTime>> {
        self.timer.as_ref().map(Timer::take)
    }

    /// Whether the adapter is a CPU rasterizer (lavapipe, SwiftShader).
    pub fn is_cpu(&self) -> bool {
        self.info.device_type == wgpu::DeviceType::Cpu
    }

    /// Largest buffer one binding may hold, bytes.
    pub(crate) fn max_binding_bytes(&self) -> u64 {
        self.limits.max_storage_buffer_binding_size.min(self.limits.max_buffer_size)
    }

    pub(crate) fn storage<T: bytemuck::Pod>(&self, label: &str, data: &[T]) -> wgpu::Buffer {
        self.uploaded.fetch_add(std::mem::size_of_val(data) as u64, Ordering::Relaxed);
        self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytemuck::cast_slice(data),
            usage: wgpu::BufferUsages::STORAGE,
        })
    }

    pub(crate) fn uniform<T: bytemuck::Pod>(&self, label: &str, data: &T) -> wgpu::Buffer {
        self.uploaded.fetch_add(std::mem::size_of::<T>() as u64, Ordering::Relaxed);
        self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytemuck::bytes_of(data),
            usage: wgpu::BufferUsages::UNIFORM,
        })
    }

    pub(crate) fn output(&self, label: &str, bytes: u64) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: bytes.max(4),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        })
    }

    pub(crate) fn bind(&self, pipeline: &wgpu::ComputePipeline, buffers: &[&wgpu::Buffer]) -> wgpu::BindGroup {
        let numbered: Vec<(u32, &wgpu::Buffer)> = buffers.iter().enumerate().map(|(i, b)| (i as u32, *b)).collect();
        self.bind_at(pipeline, &numbered)
    }

    /// [`Gpu::bind`] with each buffer at its own binding number (an entry point that
    /// uses only some of its module's bindings).
    pub(crate) fn bind_at(
        &self,
        pipeline: &wgpu::ComputePipeline,
        buffers: &[(u32, &wgpu::Buffer)],
    ) -> wgpu::BindGroup {
        let entries: Vec<wgpu::BindGroupEntry> = buffers
            .iter()
            .map(|(i, b)| wgpu::BindGroupEntry { binding: *i, resource: b.as_entire_binding() })
            .collect();
        self.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &pipeline.get_bind_group_layout(0),
            entries: &entries,
        })
    }

    /// Records `passes` (pipeline, bind group, workgroups) in order, copies `out` back
    /// and returns its bytes as `T`. Errors (validation, out of memory, a lost device)
    /// come back as [`GpuError`].
    pub(crate) fn run<T: bytemuck::Pod>(
        &self,
        passes: &[(&wgpu::ComputePipeline, &wgpu::BindGroup, [u32; 3])],
        out: &wgpu::Buffer,
    ) -> Result<Vec<T>> {
        let scope = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let size = out.size();
        let staging = self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("readback"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut enc = self.device.create_command_encoder(&Default::default());
        let pending = match &self.timer {
            None => {
                let mut pass = enc.begin_compute_pass(&Default::default());
                for (pipeline, group, [x, y, z]) in passes {
                    pass.set_pipeline(pipeline);
                    pass.set_bind_group(0, Some(*group), &[]);
                    pass.dispatch_workgroups(*x, *y, *z);
                }
                None
            }
            // One pass per dispatch, a timestamp at its start and its end.
            Some(timer) => {
                let queries = timer.queries(&self.device, passes.len());
                for (k, (pipeline, group, [x, y, z])) in passes.iter().enumerate() {
                    let mut pass = enc.begin_compute_pass(&wgpu::ComputePassDescriptor {
                        label: None,
                        timestamp_writes: Some(wgpu::ComputePassTimestampWrites {
                            query_set: &queries.0,
                            beginning_of_pass_write_index: Some(2 * k as u32),
                            end_of_pass_write_index: Some(2 * k as u32 + 1),
                        }),
                    });
                    pass.set_pipeline(pipeline);
                    pass.set_bind_group(0, Some(*group), &[]);
                    pass.dispatch_workgroups(*x, *y, *z);
                }
                let kernels = passes.iter().map(|(p, ..)| self.pipelines.name_of(p)).collect();
                Some(timer.resolve(&mut enc, queries, kernels))
            }
        };
        enc.copy_buffer_to_buffer(out, 0, &staging, 0, size);
        self.downloaded.fetch_add(size, Ordering::Relaxed);
        self.queue.submit([enc.finish()]);
        let (tx, rx) = std::sync::mpsc::channel();
        staging.slice(..).map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| GpuError::Device(format!("waiting for the device: {e}")))?;
        if let Some(e) = pollster::block_on(oom.pop()) {
            return Err(GpuError::OutOfMemory(e.to_string()));
        }
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Device(e.to_string()));
        }
        self.check_uncaptured()?;
        if let (Some(timer), Some(p)) = (&self.timer, pending) {
            timer.finish(&self.device, p);
        }
        rx.recv()
            .map_err(|_| GpuError::Device("read-back never completed".into()))?
            .map_err(|e| GpuError::Device(format!("read-back: {e}")))?;
        let data = {
            let view = staging.slice(..).get_mapped_range().map_err(|e| GpuError::Device(format!("read-back: {e}")))?;
            bytemuck::pod_collect_to_vec::<u8, T>(&view)
        };
        staging.unmap();
        Ok(data)
    }

    fn check_uncaptured(&self) -> Result<()> {
        let mut v = self.uncaptured.lock().map_err(|_| GpuError::Device("error log poisoned".into()))?;
        if v.is_empty() {
            Ok(())
        } else {
            Err(GpuError::Device(std::mem::take(&mut *v).join("; ")))
        }
    }
}

/// The backends to look on: those chosen, else `$WGPU_BACKEND` (wgpu's own variable: `vulkan`, `metal`,
/// `dx12`, `gl`, comma-separated) or every backend compiled in, the primary ones
/// (Vulkan, Metal, DX12) first, GL only where they offer no adapter.
fn backend_tiers(chosen: Option<wgpu::Backends>) -> Vec<wgpu::Backends> {
    match chosen.or_else(wgpu::Backends::from_env) {
        Some(b) => vec![b],
        None => vec![wgpu::Backends::PRIMARY, wgpu::Backends::GL],
    }
}

/// The adapter: the one whose name contains `$BPINS_GPU_ADAPTER` (any case), else the
/// high-performance one of the first backend tier that has any.
fn open_adapter(chosen: Option<wgpu::Backends>) -> Result<wgpu::Adapter> {
    let want = std::env::var("BPINS_GPU_ADAPTER").ok().filter(|w| !w.is_empty());
    let mut seen = Vec::new();
    for backends in backend_tiers(chosen) {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
            backends,
            ..wgpu::InstanceDescriptor::new_without_display_handle()
        });
        let all = pollster::block_on(instance.enumerate_adapters(backends));
        seen.extend(all.iter().map(|a| format!("{} ({:?})", a.get_info().name, a.get_info().backend)));
        if let Some(want) = &want {
            if let Some(a) = all.into_iter().find(|a| a.get_info().name.to_lowercase().contains(&want.to_lowercase())) {
                return Ok(a);
            }
            continue;
        }
        if all.is_empty() {
            continue;
        }
        if let Ok(a) = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            ..Default::default()
        })) {
            return Ok(a);
        }
    }
    Err(GpuError::NoAdapter(match want {
        Some(w) => format!("BPINS_GPU_ADAPTER={w} matches none of the adapters [{}]", seen.join(", ")),
        None if seen.is_empty() => "no Vulkan, Metal, DX12 or GL adapter".into(),
        None => format!("none of [{}] could be opened", seen.join(", ")),
    }))
}

impl Pipelines {
    /// The entry point of one of these pipelines.
    fn name_of(&self, p: &wgpu::ComputePipeline) -> &'static str {
        if p == &self.reduce_partials {
            return "reduce_partials";
        }
        if p == &self.reduce_partials_serial {
            return "reduce_partials_serial";
        }
        let made = self.specialised.lock().unwrap_or_else(|e| e.into_inner());
        made.iter().find(|(_, q)| *q == p).map_or("other", |(s, _)| s.entry)
    }

    /// The pipeline of `entry` in `module` with `constants`, made now if it is the first use.
    fn specialised(
        &self,
        device: &wgpu::Device,
        module: &wgpu::ShaderModule,
        entry: &'static str,
        constants: &[(&'static str, f64)],
    ) -> wgpu::ComputePipeline {
        let key = Specialisation { entry, constants: constants.iter().map(|(n, v)| (*n, v.to_bits())).collect() };
        let mut made = self.specialised.lock().unwrap_or_else(|e| e.into_inner());
        made.entry(key)
            .or_insert_with(|| {
                device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                    label: Some(entry),
                    layout: None,
                    module,
                    entry_point: Some(entry),
                    compilation_options: wgpu::PipelineCompilationOptions { constants, ..Default::default() },
                    cache: None,
                })
            })
            .clone()
    }

    /// The `frame_sums` pipeline of `v`.
    pub(crate) fn frame_sums(&self, device: &wgpu::Device, v: SumsVariant) -> wgpu::ComputePipeline {
        self.specialised(device, &self.sums_module, "frame_sums", &v.constants())
    }

    /// The `colour_mosaic_heading_sums` pipeline (sums.wgsl) with `constants`
    /// (`ColourSumsVariant` in colour_sums.rs).
    pub(crate) fn colour_sums(
        &self,
        device: &wgpu::Device,
        constants: &[(&'static str, f64)],
    ) -> wgpu::ComputePipeline {
        self.specialised(device, &self.sums_module, "colour_mosaic_heading_sums", constants)
    }

    /// The pipeline of a `render.wgsl` entry point running the hooks of `masks`.
    pub(crate) fn render(
        &self,
        device: &wgpu::Device,
        entry: RenderEntry,
        masks: EffectMasks,
    ) -> wgpu::ComputePipeline {
        self.specialised(device, &self.render_module, entry.name(), &masks.constants())
    }

    fn new(device: &wgpu::Device, precision: Precision) -> Result<Pipelines> {
        let module = |kernel: &str| -> Result<wgpu::ShaderModule> {
            let src =
                module_source_at(kernel, precision).ok_or_else(|| GpuError::Shader(format!("no kernel {kernel}")))?;
            Ok(device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(kernel),
                source: wgpu::ShaderSource::Wgsl(src.into()),
            }))
        };
        let reduce = module("reduce")?;
        let reduce_entry = |entry: &'static str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: None,
                module: &reduce,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        Ok(Pipelines {
            render_module: module("render")?,
            sums_module: module("sums")?,
            specialised: Mutex::new(HashMap::new()),
            reduce_partials: reduce_entry("reduce_partials"),
            reduce_partials_serial: reduce_entry("reduce_partials_serial"),
        })
    }
}
