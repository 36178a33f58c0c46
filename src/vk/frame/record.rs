//! Recording and submitting a frame: [`GpuRenderer::render`] and the passes in the order of the
//! module table.

use super::{CmoCapture, FALLBACK_PASS, GpuFrame, GpuRenderer, REFLECTOR_CHECK_PASS};
use crate::vk::backend::context::{GpuContext, Recorder};
use crate::vk::backend::error::VkResult;
use crate::vk::backend::shaders::{BOUNCE_APPEND, CONE_PREFILTER};
use crate::vk::backend::sync::{ALL, SHADER_READ, SHADER_WRITE, TRANSFER_WRITE};
use crate::vk::methods::Scope;
use crate::vk::passes::bvh::BvhQueue;

impl GpuRenderer {
    /// Records every pass, runs them and reads the frame back.
    pub fn render(&mut self, ctx: &GpuContext) -> VkResult<GpuFrame> {
        let mut ts = self.timestamps.take();
        let cmo_stages = !self.cmo_valid;
        let recorded = ctx.submit_and_wait("frame", |rec| {
            if let Some(t) = ts.as_mut() {
                t.reset(rec);
            }
            let mut scoped = |name: &str, f: &mut dyn FnMut() -> VkResult<()>| -> VkResult<()> {
                match ts.as_mut() {
                    Some(t) => {
                        let s = t.begin(rec, name)?;
                        let r = f();
                        t.end(rec, s);
                        r
                    }
                    None => {
                        rec.begin_label(name);
                        let r = f();
                        rec.end_label();
                        r
                    }
                }
            };
            self.record(rec, cmo_stages, &mut scoped)
        });
        let pass_times = match (&ts, &recorded) {
            (Some(t), Ok(())) => t.results()?,
            _ => Vec::new(),
        };
        self.timestamps = ts;
        recorded?;
        self.cmo_valid = true;
        let uploaded = cmo_stages && self.lists_pending;
        if cmo_stages {
            self.lists_pending = false;
        }
        let mut frame = self.read_back(ctx, pass_times)?;
        frame.captured = cmo_stages && self.capture.is_some() && !uploaded;
        frame.lists_uploaded = uploaded;
        Ok(frame)
    }

    /// Records the frame's passes in the order of the module docs' table; the CMO stages
    /// (capture, pyramid, the method's CMO stage) only with `cmo_stages`.
    fn record(&self, rec: &Recorder<'_>, cmo_stages: bool, scope: &mut Scope<'_>) -> VkResult<()> {
        if cmo_stages {
            self.record_cmo_stages(rec, scope)?;
        }
        scope("gbuffer", &mut || self.gbuffer.record(rec, self.background))?;
        self.record_after_gbuffer(rec, scope)
    }

    /// The CMO stages of [`GpuRenderer::record`]: the capture, the pyramid and the method's CMO
    /// stage.
    fn record_cmo_stages(&self, rec: &Recorder<'_>, scope: &mut Scope<'_>) -> VkResult<()> {
        if let Some(c) = &self.colour_capture {
            scope("capture", &mut || {
                c.record(
                    rec,
                    self.cone_cmo.as_ref().unwrap_or(&self.cmo),
                    self.background,
                )?;
                // Its copies into the CMO data complete before anything reads them.
                rec.memory_barrier(TRANSFER_WRITE, ALL);
                Ok(())
            })?;
        }
        match &self.capture {
            Some(CmoCapture::Raster(c)) => {
                scope("capture", &mut || c.record(rec, &self.cmo, self.background))?;
            }
            // Lists uploaded in place of this capture: nothing to capture.
            Some(CmoCapture::Lists(_)) if self.lists_pending => {}
            Some(CmoCapture::Lists(c)) => scope("capture", &mut || c.record(rec))?,
            None => {}
        }
        if let Some((p, b)) = &self.cone_prefilter {
            scope(CONE_PREFILTER.name, &mut || p.record(rec, b, None))?;
            rec.memory_barrier(SHADER_WRITE, SHADER_READ);
        }
        if !self.pyramid.is_empty() {
            scope("pyramid", &mut || {
                for (p, b) in &self.pyramid {
                    p.record(rec, b, None)?;
                }
                Ok(())
            })?;
            rec.memory_barrier(SHADER_WRITE, SHADER_READ);
        }
        self.method.record_cmo_stage(rec, scope)?;
        if let Some(c) = self.cone.as_ref().filter(|c| c.has_own_pyramid()) {
            scope("cone_pyramid", &mut || c.record_cmo_stage(rec))?;
        }
        Ok(())
    }

    /// The second half of [`GpuRenderer::record`]: the method's passes, the checks and the
    /// composite.
    fn record_after_gbuffer(&self, rec: &Recorder<'_>, scope: &mut Scope<'_>) -> VkResult<()> {
        // `--bounces 0`: no ray is traced.
        if self.options.bounces != 0 {
            self.method.record(rec, scope)?;
            if let Some(c) = &self.check {
                scope(REFLECTOR_CHECK_PASS, &mut || c.record(rec))?;
            }
            if let Some(b) = &self.fallback {
                scope(FALLBACK_PASS, &mut || {
                    b.record_queue(rec);
                    b.record_trace(rec)
                })?;
            }
            if let Some(c) = self.cone.as_ref().filter(|_| !self.cone_skipped) {
                scope("cone", &mut || c.record(rec))?;
            }
        }
        if let Some(b) = &self.bounce {
            let frame = super::stages::round_passes(
                self.method.as_ref(),
                self.options.bvh_bounces,
                &self.check,
                &self.fallback,
            );
            let trace = |rec: &Recorder<'_>, q: &BvhQueue| self.method.record_round(rec, q);
            scope(BOUNCE_APPEND.name, &mut || {
                b.record_own_material(rec);
                b.record_rounds(rec, frame, &trace)
            })?;
        }
        rec.memory_barrier(SHADER_WRITE, SHADER_READ);
        scope("composite", &mut || {
            self.composite.record(rec);
            Ok(())
        })
    }
}
