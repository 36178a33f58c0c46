//! Allocator-backed buffers (RAII).
//!
//! Invariants: a [`Buffer`] owns its `VkBuffer` and its allocation and holds an `Arc<Device>`, so
//! it is always destroyed before the device. Host access (`write`/`read`) is only for buffers in
//! host-visible memory (`CpuToGpu`, `GpuToCpu`); gpu-allocator picks host-coherent memory there,
//! so no flush or invalidate is needed. Device-local buffers go through staging in
//! [`GpuContext`](crate::vk::GpuContext).
use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};

use super::device::Device;
use super::error::{VkError, VkResult, alloc_err, call_err};

/// A buffer and its memory.
pub struct Buffer {
    device: Arc<Device>,
    raw: vk::Buffer,
    allocation: Option<Allocation>,
    size: u64,
    usage: vk::BufferUsageFlags,
    name: String,
}

impl Buffer {
    /// Creates a buffer of `size` bytes (rounded up to 4, never 0) in `location`.
    pub fn new(
        device: &Arc<Device>,
        name: &str,
        size: u64,
        usage: vk::BufferUsageFlags,
        location: MemoryLocation,
    ) -> VkResult<Self> {
        let size = size.max(4).next_multiple_of(4);
        let info = vk::BufferCreateInfo::default()
            .size(size)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        // SAFETY: valid create info; the buffer is destroyed in `Drop` or below on failure.
        let raw = unsafe { device.raw.create_buffer(&info, None) }
            .map_err(call_err("vkCreateBuffer", name))?;
        // SAFETY: `raw` is a live buffer of this device.
        let requirements = unsafe { device.raw.get_buffer_memory_requirements(raw) };
        let allocation = device.allocator().allocate(&AllocationCreateDesc {
            name,
            requirements,
            location,
            linear: true,
            allocation_scheme: AllocationScheme::GpuAllocatorManaged,
        });
        let allocation = match allocation {
            Ok(a) => a,
            Err(e) => {
                // SAFETY: `raw` is unused and unbound.
                unsafe { device.raw.destroy_buffer(raw, None) };
                return Err(alloc_err(name)(e));
            }
        };
        let buffer = Buffer {
            device: device.clone(),
            raw,
            allocation: Some(allocation),
            size,
            usage,
            name: name.into(),
        };
        let (memory, offset) = buffer.memory();
        // SAFETY: memory comes from an allocation sized and aligned by this buffer's requirements.
        unsafe { device.raw.bind_buffer_memory(raw, memory, offset) }
            .map_err(call_err("vkBindBufferMemory", name))?;
        device.set_name(raw, name);
        Ok(buffer)
    }

    fn memory(&self) -> (vk::DeviceMemory, u64) {
        match &self.allocation {
            // SAFETY: the allocation is alive while `self` is; the handle is only used for binding.
            Some(a) => (unsafe { a.memory() }, a.offset()),
            None => (vk::DeviceMemory::null(), 0),
        }
    }

    /// The Vulkan handle.
    pub fn raw(&self) -> vk::Buffer {
        self.raw
    }

    /// Size in bytes.
    pub fn size(&self) -> u64 {
        self.size
    }

    /// The usage flags it was created with.
    pub fn usage(&self) -> vk::BufferUsageFlags {
        self.usage
    }

    /// Debug name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Copies `data` into a host-visible buffer at byte `offset`.
    pub fn write<T: bytemuck::Pod>(&mut self, offset: u64, data: &[T]) -> VkResult<()> {
        let bytes: &[u8] = bytemuck::cast_slice(data);
        let name = self.name.clone();
        let slice = self
            .allocation
            .as_mut()
            .and_then(|a| a.mapped_slice_mut())
            .ok_or_else(|| VkError::Usage {
                what: name.clone(),
                detail: "buffer is not host-visible".into(),
            })?;
        let start = usize::try_from(offset).unwrap_or(usize::MAX);
        let dst = start
            .checked_add(bytes.len())
            .and_then(|end| slice.get_mut(start..end))
            .ok_or_else(|| VkError::Usage {
                what: name,
                detail: format!(
                    "write of {} bytes at {offset} exceeds the buffer",
                    bytes.len()
                ),
            })?;
        dst.copy_from_slice(bytes);
        Ok(())
    }

    /// Reads the whole host-visible buffer as `T`s (trailing bytes that do not fill a `T` are
    /// dropped).
    pub fn read<T: bytemuck::Pod>(&self) -> VkResult<Vec<T>> {
        let slice = self
            .allocation
            .as_ref()
            .and_then(|a| a.mapped_slice())
            .ok_or_else(|| VkError::Usage {
                what: self.name.clone(),
                detail: "buffer is not host-visible".into(),
            })?;
        let n = (self.size as usize).min(slice.len()) / size_of::<T>().max(1);
        Ok(bytemuck::pod_collect_to_vec(&slice[..n * size_of::<T>()]))
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        // SAFETY: the owner of a buffer waits for GPU work using it before dropping it (one-shot
        // submissions wait for their fence); the handle is destroyed once.
        unsafe { self.device.raw.destroy_buffer(self.raw, None) };
        if let Some(a) = self.allocation.take()
            && let Err(e) = self.device.allocator().free(a)
        {
            log::error!("freeing memory of buffer `{}` failed: {e}", self.name);
        }
    }
}
