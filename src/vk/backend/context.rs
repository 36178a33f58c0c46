//! [`GpuContext`]: instance, device, queue, command pool and allocator, plus one-shot
//! "record, submit, wait" and staging upload/readback helpers.
//!
//! Invariants:
//! - Destruction order is by ownership: `GpuContext` destroys its fence and command pool in
//!   `Drop`, then releases its `Arc<Device>`; the device (and allocator) goes when the last
//!   resource holding an `Arc<Device>` goes; the instance (and debug messenger) after that. Hence
//!   the validation layer sees no leaked object at device destruction.
//! - [`GpuContext::submit_and_wait`] returns only after the GPU finished, so resources used by the
//!   recorded commands may be dropped as soon as it returns.
use std::sync::{Arc, Mutex};

use ash::vk;
use gpu_allocator::MemoryLocation;

use super::buffer::Buffer;
use super::device::{Device, EnabledFeatures};
use super::error::{VkError, VkResult, call_err};
use super::image::Image;
use super::info::{DeviceReport, probe_all};
use super::instance::{Instance, Validation, ValidationLog};
use super::sync::{ALL, Access, COLOUR_WRITE, DEPTH_WRITE, TRANSFER_READ, TRANSFER_WRITE};

/// How to create a [`GpuContext`]. `Default` is: no validation (unless `CUBETRACE_VALIDATION=1`),
/// automatic device choice.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ContextOptions {
    pub validation: Validation,
    /// `--device N`: index in enumeration order; `None` picks (discrete GPU first).
    pub device_index: Option<usize>,
}

impl ContextOptions {
    /// What tests use: validation when the layer is installed, automatic device.
    pub fn for_tests() -> Self {
        ContextOptions {
            validation: Validation::IfAvailable,
            device_index: None,
        }
    }
}

/// Records commands into a one-shot command buffer.
pub struct Recorder<'a> {
    pub(crate) device: &'a Device,
    pub(crate) cmd: vk::CommandBuffer,
}

impl Recorder<'_> {
    /// The command buffer being recorded.
    pub fn raw(&self) -> vk::CommandBuffer {
        self.cmd
    }

    /// Opens a debug label (no-op without debug utils). Pair with [`Recorder::end_label`].
    pub fn begin_label(&self, name: &str) {
        let Some(du) = &self.device.debug_utils else {
            return;
        };
        let Ok(name) = std::ffi::CString::new(name) else {
            return;
        };
        let label = vk::DebugUtilsLabelEXT::default().label_name(&name);
        // SAFETY: `cmd` is in the recording state; the label string outlives the call.
        unsafe { du.cmd_begin_debug_utils_label(self.cmd, &label) };
    }

    /// Closes the innermost debug label.
    pub fn end_label(&self) {
        let Some(du) = &self.device.debug_utils else {
            return;
        };
        // SAFETY: `cmd` is recording and a label was opened by `begin_label`.
        unsafe { du.cmd_end_debug_utils_label(self.cmd) };
    }

    /// A global memory barrier (synchronization2).
    pub fn memory_barrier(
        &self,
        src: (vk::PipelineStageFlags2, vk::AccessFlags2),
        dst: (vk::PipelineStageFlags2, vk::AccessFlags2),
    ) {
        let barrier = [vk::MemoryBarrier2::default()
            .src_stage_mask(src.0)
            .src_access_mask(src.1)
            .dst_stage_mask(dst.0)
            .dst_access_mask(dst.1)];
        let dep = vk::DependencyInfo::default().memory_barriers(&barrier);
        // SAFETY: `cmd` is recording; synchronization2 is enabled on every device we create.
        unsafe { self.device.raw.cmd_pipeline_barrier2(self.cmd, &dep) };
    }

    /// A layout transition of every layer of `image`, with a full barrier between `src` and `dst`.
    pub fn image_barrier(
        &self,
        image: &Image,
        old: vk::ImageLayout,
        new: vk::ImageLayout,
        src: (vk::PipelineStageFlags2, vk::AccessFlags2),
        dst: (vk::PipelineStageFlags2, vk::AccessFlags2),
    ) {
        let barrier = [vk::ImageMemoryBarrier2::default()
            .src_stage_mask(src.0)
            .src_access_mask(src.1)
            .dst_stage_mask(dst.0)
            .dst_access_mask(dst.1)
            .old_layout(old)
            .new_layout(new)
            .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
            .image(image.raw())
            .subresource_range(image.range(0, image.desc().layers))];
        let dep = vk::DependencyInfo::default().image_memory_barriers(&barrier);
        // SAFETY: `cmd` is recording; the image is alive for the submission.
        unsafe { self.device.raw.cmd_pipeline_barrier2(self.cmd, &dep) };
    }

    /// Makes `colour` images and an optional `depth` image writable as attachments, discarding
    /// their contents (the draw clears them), after `previous` (the accesses of the last use).
    pub fn prepare_render_targets(
        &self,
        colour: &[&Image],
        depth: Option<&Image>,
        previous: Access,
    ) {
        for img in colour {
            self.image_barrier(
                img,
                vk::ImageLayout::UNDEFINED,
                vk::ImageLayout::COLOR_ATTACHMENT_OPTIMAL,
                previous,
                COLOUR_WRITE,
            );
        }
        if let Some(d) = depth {
            self.image_barrier(
                d,
                vk::ImageLayout::UNDEFINED,
                vk::ImageLayout::DEPTH_ATTACHMENT_OPTIMAL,
                DEPTH_WRITE,
                DEPTH_WRITE,
            );
        }
    }

    /// Fills all of `buffer` (created with `TRANSFER_DST`) with the 32-bit word `value`.
    pub fn fill_buffer(&self, buffer: &Buffer, value: u32) {
        // SAFETY: `cmd` is recording; the buffer is alive for the submission, its size is a
        // multiple of 4 (`Buffer::new` rounds up) and WHOLE_SIZE stays inside it.
        unsafe {
            self.device
                .raw
                .cmd_fill_buffer(self.cmd, buffer.raw(), 0, vk::WHOLE_SIZE, value)
        };
    }

    /// Copies `size` bytes from the start of `src` to the start of `dst`.
    pub fn copy_buffer(&self, src: &Buffer, dst: &Buffer, size: u64) {
        self.copy_buffer_to(src, dst, 0, size);
    }

    /// Copies `size` bytes from the start of `src` to `dst` at byte `offset`.
    pub fn copy_buffer_to(&self, src: &Buffer, dst: &Buffer, offset: u64, size: u64) {
        let region = [vk::BufferCopy::default().dst_offset(offset).size(size)];
        // SAFETY: both buffers are alive for the submission and at least `size` bytes long
        // (checked by callers in this module).
        unsafe {
            self.device
                .raw
                .cmd_copy_buffer(self.cmd, src.raw(), dst.raw(), &region)
        };
    }
}

impl Recorder<'_> {
    /// Copies every layer of `image` (in `TRANSFER_SRC_OPTIMAL`) into `buffer` from its start,
    /// tightly packed, layer-major, row-major.
    pub fn copy_image_to_buffer(&self, image: &Image, buffer: &Buffer) -> VkResult<()> {
        let desc = image.desc();
        let bytes = desc.layer_bytes()? * u64::from(desc.layers);
        if buffer.size() < bytes {
            return Err(VkError::Usage {
                what: buffer.name().into(),
                detail: format!(
                    "{} bytes, image `{}` holds {bytes}",
                    buffer.size(),
                    desc.name
                ),
            });
        }
        let region = [copy_region(image)];
        // SAFETY: the image is in TRANSFER_SRC_OPTIMAL (caller's contract); the buffer fits every
        // layer (checked above); both are alive for the submission.
        unsafe {
            self.device.raw.cmd_copy_image_to_buffer(
                self.cmd,
                image.raw(),
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                buffer.raw(),
                &region,
            )
        };
        Ok(())
    }
}

/// The Vulkan context: everything a pass needs to create resources and submit work.
pub struct GpuContext {
    /// Guarded: command pools need external synchronisation.
    pool: Mutex<vk::CommandPool>,
    fence: vk::Fence,
    log: Arc<ValidationLog>,
    device: Arc<Device>,
}

impl GpuContext {
    /// Creates instance, device, queue, command pool and allocator.
    pub fn new(options: ContextOptions) -> VkResult<Self> {
        let instance = Arc::new(Instance::new(options.validation)?);
        let log = instance.validation_log().clone();
        let device = Arc::new(Device::new(instance, options.device_index)?);
        let info = vk::CommandPoolCreateInfo::default()
            .queue_family_index(device.queue_family)
            .flags(vk::CommandPoolCreateFlags::TRANSIENT);
        // SAFETY: valid create info for a queue family of this device.
        let pool = unsafe { device.raw.create_command_pool(&info, None) }
            .map_err(call_err("vkCreateCommandPool", "context"))?;
        // SAFETY: plain fence creation.
        let fence = match unsafe {
            device
                .raw
                .create_fence(&vk::FenceCreateInfo::default(), None)
        } {
            Ok(f) => f,
            Err(e) => {
                // SAFETY: the pool has no command buffers yet.
                unsafe { device.raw.destroy_command_pool(pool, None) };
                return Err(call_err("vkCreateFence", "context")(e));
            }
        };
        Ok(GpuContext {
            pool: Mutex::new(pool),
            fence,
            log,
            device,
        })
    }

    /// Probes every device without creating one (backs `cubetrace info`).
    pub fn list_devices(validation: Validation) -> VkResult<Vec<DeviceReport>> {
        let instance = Instance::new(validation)?;
        let devices = probe_all(&instance)?;
        if devices.is_empty() {
            return Err(VkError::NoDriver {
                detail: "the Vulkan loader found no physical device".into(),
            });
        }
        Ok(devices.into_iter().map(|(_, r)| r).collect())
    }

    /// The shared device (resources hold an `Arc` of it).
    pub fn device(&self) -> &Arc<Device> {
        &self.device
    }

    /// The chosen device's report.
    pub fn report(&self) -> &DeviceReport {
        &self.device.report
    }

    /// The size of the device's largest device-local memory heap, in bytes: the most a
    /// render's buffers and images can take.
    pub fn device_local_heap_bytes(&self) -> u64 {
        // SAFETY: `physical` was enumerated from this instance, which outlives the device.
        let props = unsafe {
            self.device
                .instance
                .raw
                .get_physical_device_memory_properties(self.device.physical)
        };
        props
            .memory_heaps_as_slice()
            .iter()
            .filter(|h| h.flags.contains(vk::MemoryHeapFlags::DEVICE_LOCAL))
            .map(|h| h.size)
            .max()
            .unwrap_or(0)
    }

    /// Whether the device is a CPU implementation (lavapipe): its device memory is the
    /// machine's memory.
    pub fn device_is_cpu(&self) -> bool {
        self.device.report.device_type == vk::PhysicalDeviceType::CPU
    }

    /// Optional features that are enabled.
    pub fn enabled_features(&self) -> EnabledFeatures {
        self.device.enabled
    }

    /// Whether the Khronos validation layer is active.
    pub fn validation_enabled(&self) -> bool {
        self.device.instance.validation
    }

    /// Whether debug labels and object names are recorded (VK_EXT_debug_utils).
    pub fn debug_utils_enabled(&self) -> bool {
        self.device.debug_utils.is_some()
    }

    /// Error messages reported so far by the validation layer (empty without it).
    pub fn validation_errors(&self) -> Vec<String> {
        self.log.errors()
    }

    /// The validation log; keep a clone to read messages reported during destruction.
    pub fn validation_log(&self) -> Arc<ValidationLog> {
        self.log.clone()
    }

    /// Records commands with `record`, submits them and waits for the GPU. `name` labels the
    /// command buffer in errors and debuggers.
    pub fn submit_and_wait<R>(
        &self,
        name: &str,
        record: impl FnOnce(&Recorder<'_>) -> VkResult<R>,
    ) -> VkResult<R> {
        let dev = &self.device.raw;
        let pool = self.pool.lock().unwrap_or_else(|p| p.into_inner());
        let info = vk::CommandBufferAllocateInfo::default()
            .command_pool(*pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        // SAFETY: the pool is locked (externally synchronised) and alive.
        let cmds = unsafe { dev.allocate_command_buffers(&info) }
            .map_err(call_err("vkAllocateCommandBuffers", name))?;
        let cmd = cmds[0];
        self.device.set_name(cmd, name);
        let result = self.record_submit(cmd, name, record);
        // SAFETY: the submission (if any) completed (fence waited) or never happened.
        unsafe { dev.free_command_buffers(*pool, &cmds) };
        result
    }

    fn record_submit<R>(
        &self,
        cmd: vk::CommandBuffer,
        name: &str,
        record: impl FnOnce(&Recorder<'_>) -> VkResult<R>,
    ) -> VkResult<R> {
        let dev = &self.device.raw;
        let begin = vk::CommandBufferBeginInfo::default()
            .flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        // SAFETY: `cmd` is freshly allocated (initial state).
        unsafe { dev.begin_command_buffer(cmd, &begin) }
            .map_err(call_err("vkBeginCommandBuffer", name))?;
        let recorder = Recorder {
            device: &self.device,
            cmd,
        };
        let recorded = record(&recorder);
        // SAFETY: `cmd` is in the recording state.
        let ended =
            unsafe { dev.end_command_buffer(cmd) }.map_err(call_err("vkEndCommandBuffer", name));
        let value = recorded?;
        ended?;
        let cmd_infos = [vk::CommandBufferSubmitInfo::default().command_buffer(cmd)];
        let submit = [vk::SubmitInfo2::default().command_buffer_infos(&cmd_infos)];
        // SAFETY: `cmd` is executable; the fence is unsignalled (reset after every wait); the queue
        // is only used from here, under the pool lock.
        unsafe { dev.queue_submit2(self.device.queue, &submit, self.fence) }
            .map_err(|e| self.lost(name, e))?;
        // SAFETY: the fence was just submitted.
        let waited = unsafe { dev.wait_for_fences(&[self.fence], true, u64::MAX) }
            .map_err(|e| self.lost(name, e));
        // SAFETY: the fence is not in use by a pending submission any more (or the device is lost).
        let reset =
            unsafe { dev.reset_fences(&[self.fence]) }.map_err(call_err("vkResetFences", name));
        waited?;
        reset?;
        Ok(value)
    }

    /// Error for a failed submission or wait; on `DEVICE_LOST` it names the last submission.
    fn lost(&self, name: &str, result: vk::Result) -> VkError {
        if result == vk::Result::ERROR_DEVICE_LOST {
            log::error!("device lost while running `{name}`");
        }
        VkError::Call {
            call: "vkQueueSubmit2/vkWaitForFences",
            what: name.into(),
            result,
        }
    }

    /// Creates a device-local buffer filled with `data` via a staging buffer.
    pub fn create_buffer_init<T: bytemuck::Pod>(
        &self,
        name: &str,
        usage: vk::BufferUsageFlags,
        data: &[T],
    ) -> VkResult<Buffer> {
        let bytes = size_of_val(data) as u64;
        let mut staging = Buffer::new(
            &self.device,
            &format!("{name} (staging)"),
            bytes,
            vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::CpuToGpu,
        )?;
        staging.write(0, data)?;
        let buffer = Buffer::new(
            &self.device,
            name,
            bytes,
            usage | vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuOnly,
        )?;
        self.submit_and_wait(&format!("upload {name}"), |rec| {
            rec.copy_buffer(&staging, &buffer, staging.size());
            rec.memory_barrier(TRANSFER_WRITE, ALL);
            Ok(())
        })?;
        Ok(buffer)
    }

    /// Writes `data` to the start of `buffer` (created with `TRANSFER_DST`) via a staging buffer.
    pub fn write_buffer<T: bytemuck::Pod>(&self, buffer: &Buffer, data: &[T]) -> VkResult<()> {
        let bytes = size_of_val(data) as u64;
        if bytes > buffer.size() {
            return Err(VkError::Usage {
                what: buffer.name().into(),
                detail: format!("write of {bytes} bytes into {} bytes", buffer.size()),
            });
        }
        let mut staging = Buffer::new(
            &self.device,
            &format!("{} (staging)", buffer.name()),
            bytes,
            vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::CpuToGpu,
        )?;
        staging.write(0, data)?;
        self.submit_and_wait(&format!("write {}", buffer.name()), |rec| {
            rec.memory_barrier(ALL, TRANSFER_WRITE);
            rec.copy_buffer(&staging, buffer, bytes);
            rec.memory_barrier(TRANSFER_WRITE, ALL);
            Ok(())
        })
    }

    /// Reads a buffer (created with `TRANSFER_SRC`) back as `T`s via a staging buffer.
    pub fn read_buffer<T: bytemuck::Pod>(&self, buffer: &Buffer) -> VkResult<Vec<T>> {
        let staging = Buffer::new(
            &self.device,
            &format!("{} (readback)", buffer.name()),
            buffer.size(),
            vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
        )?;
        self.submit_and_wait(&format!("read back {}", buffer.name()), |rec| {
            rec.memory_barrier(ALL, TRANSFER_READ);
            rec.copy_buffer(buffer, &staging, buffer.size());
            rec.memory_barrier(
                TRANSFER_WRITE,
                (vk::PipelineStageFlags2::HOST, vk::AccessFlags2::HOST_READ),
            );
            Ok(())
        })?;
        staging.read()
    }

    /// Uploads tightly packed, layer-major texels into every layer of `image` (created with
    /// `TRANSFER_DST`) and leaves it in `final_layout`.
    pub fn upload_image(
        &self,
        image: &Image,
        texels: &[u8],
        final_layout: vk::ImageLayout,
    ) -> VkResult<()> {
        let desc = image.desc();
        let expected = desc.layer_bytes()? * u64::from(desc.layers);
        if texels.len() as u64 != expected {
            return Err(VkError::Usage {
                what: desc.name.clone(),
                detail: format!("upload of {} bytes, image holds {expected}", texels.len()),
            });
        }
        let mut staging = Buffer::new(
            &self.device,
            &format!("{} (staging)", desc.name),
            expected,
            vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::CpuToGpu,
        )?;
        staging.write(0, texels)?;
        self.submit_and_wait(&format!("upload {}", desc.name), |rec| {
            rec.image_barrier(
                image,
                vk::ImageLayout::UNDEFINED,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                ALL,
                TRANSFER_WRITE,
            );
            let region = [copy_region(image)];
            // SAFETY: the image is in TRANSFER_DST_OPTIMAL; the staging buffer holds every layer.
            unsafe {
                self.device.raw.cmd_copy_buffer_to_image(
                    rec.cmd,
                    staging.raw(),
                    image.raw(),
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    &region,
                )
            };
            rec.image_barrier(
                image,
                vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                final_layout,
                TRANSFER_WRITE,
                ALL,
            );
            Ok(())
        })
    }

    /// Reads every layer of `image` (created with `TRANSFER_SRC`, currently in `layout`) back as
    /// tightly packed, layer-major texels; the image is returned to `layout`.
    pub fn read_image(&self, image: &Image, layout: vk::ImageLayout) -> VkResult<Vec<u8>> {
        let desc = image.desc();
        let bytes = desc.layer_bytes()? * u64::from(desc.layers);
        let staging = Buffer::new(
            &self.device,
            &format!("{} (readback)", desc.name),
            bytes,
            vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
        )?;
        self.submit_and_wait(&format!("read back {}", desc.name), |rec| {
            rec.image_barrier(
                image,
                layout,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                ALL,
                TRANSFER_READ,
            );
            let region = [copy_region(image)];
            // SAFETY: the image is in TRANSFER_SRC_OPTIMAL; the staging buffer fits every layer.
            unsafe {
                self.device.raw.cmd_copy_image_to_buffer(
                    rec.cmd,
                    image.raw(),
                    vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                    staging.raw(),
                    &region,
                )
            };
            let back = if layout == vk::ImageLayout::UNDEFINED {
                vk::ImageLayout::GENERAL
            } else {
                layout
            };
            rec.image_barrier(
                image,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                back,
                TRANSFER_READ,
                ALL,
            );
            rec.memory_barrier(
                TRANSFER_WRITE,
                (vk::PipelineStageFlags2::HOST, vk::AccessFlags2::HOST_READ),
            );
            Ok(())
        })?;
        let mut out: Vec<u8> = staging.read()?;
        out.truncate(bytes as usize);
        Ok(out)
    }
}

fn copy_region(image: &Image) -> vk::BufferImageCopy {
    let d = image.desc();
    vk::BufferImageCopy::default()
        .image_subresource(
            vk::ImageSubresourceLayers::default()
                .aspect_mask(d.aspect())
                .mip_level(0)
                .base_array_layer(0)
                .layer_count(d.layers),
        )
        .image_extent(vk::Extent3D {
            width: d.width,
            height: d.height,
            depth: 1,
        })
}

impl Drop for GpuContext {
    fn drop(&mut self) {
        // SAFETY: the device is alive (we hold an `Arc`); waiting first makes the pool and fence unused.
        if let Err(e) = unsafe { self.device.raw.device_wait_idle() } {
            log::error!("vkDeviceWaitIdle failed: {e}");
        }
        let pool = *self.pool.get_mut().unwrap_or_else(|p| p.into_inner());
        // SAFETY: no command buffer from this pool is pending; every one was freed after its wait.
        unsafe { self.device.raw.destroy_command_pool(pool, None) };
        // SAFETY: the fence is not part of any pending submission.
        unsafe { self.device.raw.destroy_fence(self.fence, None) };
    }
}
