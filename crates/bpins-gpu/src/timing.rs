//! Per-kernel device time from timestamp queries, where the adapter offers them
//! (`wgpu::Features::TIMESTAMP_QUERY`): each dispatch of [`crate::Gpu`]'s `run` gets a
//! compute pass of its own with a timestamp at its start and end, resolved and read back
//! with the results; the times add up per kernel until [`crate::Gpu::take_kernel_times`].
//! Without the feature nothing is recorded, and `take_kernel_times` says so (`None`).

use std::collections::BTreeMap;
use std::sync::Mutex;

/// One kernel's device time since the last take.
#[derive(Clone, Debug, PartialEq)]
pub struct KernelTime {
    /// The entry point (`frame_sums`, `reduce_partials`, `render_mosaic`, …).
    pub kernel: &'static str,
    pub dispatches: u64,
    /// Device time of all its dispatches, milliseconds.
    pub total_ms: f64,
}

pub(crate) struct Timer {
    /// Nanoseconds per timestamp tick.
    period_ns: f64,
    totals: Mutex<BTreeMap<&'static str, (u64, f64)>>,
}

/// The queries of one submission, to be read once the device is idle.
pub(crate) struct Pending {
    kernels: Vec<&'static str>,
    readback: wgpu::Buffer,
}

impl Timer {
    pub(crate) fn new(queue: &wgpu::Queue) -> Timer {
        Timer { period_ns: queue.get_timestamp_period() as f64, totals: Mutex::new(BTreeMap::new()) }
    }

    /// A query set of two timestamps per kernel, and where they will be resolved.
    pub(crate) fn queries(&self, device: &wgpu::Device, n: usize) -> (wgpu::QuerySet, wgpu::Buffer, wgpu::Buffer) {
        let count = 2 * n as u32;
        let set = device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("kernel timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count,
        });
        let bytes = 8 * count as u64;
        let resolve = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamps"),
            size: bytes,
            usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let readback = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("timestamps read-back"),
            size: bytes,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        (set, resolve, readback)
    }

    /// Resolves `set` into `resolve`, copies it to `readback` and asks to map it.
    pub(crate) fn resolve(
        &self,
        enc: &mut wgpu::CommandEncoder,
        (set, resolve, readback): (wgpu::QuerySet, wgpu::Buffer, wgpu::Buffer),
        kernels: Vec<&'static str>,
    ) -> Pending {
        let n = 2 * kernels.len() as u32;
        enc.resolve_query_set(&set, 0..n, &resolve, 0);
        enc.copy_buffer_to_buffer(&resolve, 0, &readback, 0, resolve.size());
        Pending { kernels, readback }
    }

    /// After the submission completed: adds each kernel's end − start.
    pub(crate) fn finish(&self, device: &wgpu::Device, p: Pending) {
        p.readback.slice(..).map_async(wgpu::MapMode::Read, |_| {});
        let _ = device.poll(wgpu::PollType::wait_indefinitely());
        let Ok(view) = p.readback.slice(..).get_mapped_range() else { return };
        let ticks: Vec<u64> = bytemuck::pod_collect_to_vec(&view);
        drop(view);
        p.readback.unmap();
        if let Ok(mut t) = self.totals.lock() {
            for (k, name) in p.kernels.iter().enumerate() {
                let dt = ticks[2 * k + 1].saturating_sub(ticks[2 * k]) as f64 * self.period_ns * 1e-6;
                let e = t.entry(name).or_insert((0, 0.0));
                e.0 += 1;
                e.1 += dt;
            }
        }
    }

    pub(crate) fn take(&self) -> Vec<KernelTime> {
        let Ok(mut t) = self.totals.lock() else { return Vec::new() };
        std::mem::take(&mut *t)
            .into_iter()
            .map(|(kernel, (dispatches, total_ms))| KernelTime { kernel, dispatches, total_ms })
            .collect()
    }
}
