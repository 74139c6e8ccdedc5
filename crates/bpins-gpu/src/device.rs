//! The device: a Vulkan adapter with f64 shaders, its pipelines, and buffer plumbing.

use crate::shaders::module_source;
use crate::{GpuError, Result};
use std::sync::{Arc, Mutex};
use wgpu::util::DeviceExt;

/// A GPU ready to run the bpins kernels.
pub struct Gpu {
    pub(crate) device: wgpu::Device,
    pub(crate) queue: wgpu::Queue,
    info: wgpu::AdapterInfo,
    pub(crate) limits: wgpu::Limits,
    pub(crate) pipelines: Pipelines,
    /// Errors wgpu reports outside an error scope (kept, never a panic).
    uncaptured: Arc<Mutex<Vec<String>>>,
}

pub(crate) struct Pipelines {
    pub render_mosaic: wgpu::ComputePipeline,
    pub render_colocated: wgpu::ComputePipeline,
    pub chain_maps: wgpu::ComputePipeline,
    pub sky_maps: wgpu::ComputePipeline,
    pub frame_sums: wgpu::ComputePipeline,
    pub reduce_partials: wgpu::ComputePipeline,
}

impl Gpu {
    /// Opens the best Vulkan adapter (a discrete GPU before an integrated one before
    /// Mesa lavapipe), or the one whose name contains `$BPINS_GPU_ADAPTER`. Errors,
    /// never panics, when there is none or it lacks f64 shaders.
    pub fn new() -> Result<Gpu> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
            backends: wgpu::Backends::VULKAN,
            ..wgpu::InstanceDescriptor::new_without_display_handle()
        });
        let adapter = match std::env::var("BPINS_GPU_ADAPTER") {
            // A named adapter: the first whose name contains the text (any case).
            Ok(want) if !want.is_empty() => {
                let all = pollster::block_on(instance.enumerate_adapters(wgpu::Backends::VULKAN));
                let names: Vec<String> = all.iter().map(|a| a.get_info().name).collect();
                all.into_iter().find(|a| a.get_info().name.to_lowercase().contains(&want.to_lowercase())).ok_or_else(
                    || {
                        GpuError::NoAdapter(format!(
                            "BPINS_GPU_ADAPTER={want} matches none of the Vulkan adapters [{}]",
                            names.join(", ")
                        ))
                    },
                )?
            }
            _ => pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                ..Default::default()
            }))
            .map_err(|e| GpuError::NoAdapter(e.to_string()))?,
        };
        let info = adapter.get_info();
        if !adapter.features().contains(wgpu::Features::SHADER_F64) {
            return Err(GpuError::MissingFeature {
                adapter: info.name.clone(),
                feature: "SHADER_F64 (f64 in shaders)",
            });
        }
        let limits = adapter.limits();
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("bpins"),
            required_features: wgpu::Features::SHADER_F64,
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
        let pipelines = Pipelines::new(&device)?;
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(GpuError::Shader(e.to_string()));
        }
        Ok(Gpu { device, queue, info, limits, pipelines, uncaptured })
    }

    /// The adapter, as "name (driver, backend)".
    pub fn adapter_name(&self) -> String {
        let i = &self.info;
        let driver =
            if i.driver_info.is_empty() { i.driver.clone() } else { format!("{} {}", i.driver, i.driver_info) };
        format!("{} ({}, {:?})", i.name, driver, i.backend)
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
        self.device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some(label),
            contents: bytemuck::cast_slice(data),
            usage: wgpu::BufferUsages::STORAGE,
        })
    }

    pub(crate) fn uniform<T: bytemuck::Pod>(&self, label: &str, data: &T) -> wgpu::Buffer {
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
        let entries: Vec<wgpu::BindGroupEntry> = buffers
            .iter()
            .enumerate()
            .map(|(i, b)| wgpu::BindGroupEntry { binding: i as u32, resource: b.as_entire_binding() })
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
        {
            let mut pass = enc.begin_compute_pass(&Default::default());
            for (pipeline, group, [x, y, z]) in passes {
                pass.set_pipeline(pipeline);
                pass.set_bind_group(0, Some(*group), &[]);
                pass.dispatch_workgroups(*x, *y, *z);
            }
        }
        enc.copy_buffer_to_buffer(out, 0, &staging, 0, size);
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

impl Pipelines {
    fn new(device: &wgpu::Device) -> Result<Pipelines> {
        let module = |kernel: &str| -> Result<wgpu::ShaderModule> {
            let src = module_source(kernel).ok_or_else(|| GpuError::Shader(format!("no kernel {kernel}")))?;
            Ok(device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(kernel),
                source: wgpu::ShaderSource::Wgsl(src.into()),
            }))
        };
        let pipeline = |m: &wgpu::ShaderModule, entry: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(entry),
                layout: None,
                module: m,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let (render, sums, reduce) = (module("render")?, module("sums")?, module("reduce")?);
        Ok(Pipelines {
            render_mosaic: pipeline(&render, "render_mosaic"),
            render_colocated: pipeline(&render, "render_colocated"),
            chain_maps: pipeline(&render, "chain_maps"),
            sky_maps: pipeline(&render, "sky_maps"),
            frame_sums: pipeline(&sums, "frame_sums"),
            reduce_partials: pipeline(&reduce, "reduce_partials"),
        })
    }
}
