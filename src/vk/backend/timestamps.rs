//! GPU timestamps keyed by pass name.
//!
//! Invariants: each scope writes two timestamps (start, end) into a query pool reset in the same
//! command buffer before use; the scope's name is also its debug label. Durations are
//! `(end - start) mod 2^timestampValidBits` ticks times `timestampPeriod`, in nanoseconds, so
//! they are never negative.
use std::sync::Arc;

use ash::vk;

use super::context::{GpuContext, Recorder};
use super::device::Device;
use super::error::{VkError, VkResult, call_err};

/// A timestamp query pool holding up to `capacity` named scopes.
pub struct Timestamps {
    device: Arc<Device>,
    pool: vk::QueryPool,
    capacity: u32,
    names: Vec<String>,
    period_ns: f64,
    mask: u64,
}

/// `(pass name, nanoseconds)`: one timed scope.
pub type PassTime = (String, f64);

/// An open scope returned by [`Timestamps::begin`].
#[must_use = "close the scope with Timestamps::end"]
pub struct Scope(u32);

impl Timestamps {
    /// Creates a pool for `capacity` scopes; fails with `MissingFeature` where the queue has no
    /// timestamps.
    pub fn new(ctx: &GpuContext, capacity: u32) -> VkResult<Self> {
        let r = ctx.report();
        if !r.timestamps_supported() {
            return Err(VkError::MissingFeature {
                device: r.name.clone(),
                feature: "timestamp queries".into(),
            });
        }
        let device = ctx.device().clone();
        let info = vk::QueryPoolCreateInfo::default()
            .query_type(vk::QueryType::TIMESTAMP)
            .query_count(capacity * 2);
        // SAFETY: valid create info.
        let pool = unsafe { device.raw.create_query_pool(&info, None) }
            .map_err(call_err("vkCreateQueryPool", "timestamps"))?;
        let mask = if r.timestamp_valid_bits >= 64 {
            u64::MAX
        } else {
            (1u64 << r.timestamp_valid_bits) - 1
        };
        Ok(Timestamps {
            device,
            pool,
            capacity,
            names: Vec::new(),
            period_ns: f64::from(r.timestamp_period_ns),
            mask,
        })
    }

    /// Resets every query and forgets previous scopes. Record before the first `begin`.
    pub fn reset(&mut self, rec: &Recorder<'_>) {
        self.names.clear();
        // SAFETY: `rec` is recording, outside a render pass; the range is within the pool.
        unsafe {
            self.device
                .raw
                .cmd_reset_query_pool(rec.raw(), self.pool, 0, self.capacity * 2)
        };
    }

    /// Opens the scope `name`: debug label + start timestamp.
    pub fn begin(&mut self, rec: &Recorder<'_>, name: &str) -> VkResult<Scope> {
        let i = self.names.len() as u32;
        if i >= self.capacity {
            return Err(VkError::Usage {
                what: name.into(),
                detail: format!("more than {} timestamp scopes", self.capacity),
            });
        }
        self.names.push(name.into());
        rec.begin_label(name);
        // SAFETY: query 2i was reset in this command buffer and is written once.
        unsafe {
            self.device.raw.cmd_write_timestamp2(
                rec.raw(),
                vk::PipelineStageFlags2::ALL_COMMANDS,
                self.pool,
                2 * i,
            )
        };
        Ok(Scope(i))
    }

    /// Closes a scope: end timestamp + end of the debug label.
    pub fn end(&mut self, rec: &Recorder<'_>, scope: Scope) {
        // SAFETY: query 2i+1 was reset in this command buffer and is written once.
        unsafe {
            self.device.raw.cmd_write_timestamp2(
                rec.raw(),
                vk::PipelineStageFlags2::ALL_COMMANDS,
                self.pool,
                2 * scope.0 + 1,
            )
        };
        rec.end_label();
    }

    /// `(pass name, nanoseconds)` per scope, in recording order. Call after the submission
    /// finished.
    pub fn results(&self) -> VkResult<Vec<PassTime>> {
        let n = self.names.len();
        if n == 0 {
            return Ok(Vec::new());
        }
        let mut ticks = vec![0u64; 2 * n];
        // SAFETY: the queries 0..2n were written by a completed submission; `ticks` holds 2n u64s.
        unsafe {
            self.device.raw.get_query_pool_results(
                self.pool,
                0,
                &mut ticks,
                vk::QueryResultFlags::TYPE_64 | vk::QueryResultFlags::WAIT,
            )
        }
        .map_err(call_err("vkGetQueryPoolResults", "timestamps"))?;
        Ok(self
            .names
            .iter()
            .enumerate()
            .map(|(i, name)| {
                let dt = ticks[2 * i + 1].wrapping_sub(ticks[2 * i]) & self.mask;
                (name.clone(), dt as f64 * self.period_ns)
            })
            .collect())
    }
}

impl Drop for Timestamps {
    fn drop(&mut self) {
        // SAFETY: no pending submission writes this pool.
        unsafe { self.device.raw.destroy_query_pool(self.pool, None) };
    }
}
