//! Allocator-backed 2-D and cube-compatible images with their views (RAII).
//!
//! Invariants:
//! - Layers are cube faces in Vulkan's order (+X, −X, +Y, −Y, +Z, −Z) when `cube` is set; a cube
//!   image has `layers` a multiple of 6 and is created `CUBE_COMPATIBLE`.
//! - Views: `view` is the natural one (`CUBE`/`CUBE_ARRAY` for cube images, else `2D`/`2D_ARRAY`);
//!   `array_view` is always `2D_ARRAY` over every layer (WGSL `textureLoad` cannot address a cube,
//!   see NAGA-LAVAPIPE.md); `layer_views[i]` is a `2D` view of layer `i` (render target for one
//!   face). Depth formats get the `DEPTH` aspect, others `COLOR`.
//! - Texel data crossing the host boundary is tightly packed, layer-major, row-major.
use std::sync::Arc;

use ash::vk;
use gpu_allocator::MemoryLocation;
use gpu_allocator::vulkan::{Allocation, AllocationCreateDesc, AllocationScheme};

use super::conv;
use super::device::Device;
use super::error::{VkError, VkResult, alloc_err, call_err};

/// What to create.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ImageDesc {
    pub name: String,
    pub format: vk::Format,
    pub width: u32,
    pub height: u32,
    /// Array layers (6 for one cube).
    pub layers: u32,
    /// Create `CUBE_COMPATIBLE` and a cube `view`.
    pub cube: bool,
    pub usage: vk::ImageUsageFlags,
}

impl ImageDesc {
    /// A single-layer 2-D image.
    pub fn d2(
        name: &str,
        format: vk::Format,
        width: u32,
        height: u32,
        usage: vk::ImageUsageFlags,
    ) -> Self {
        ImageDesc {
            name: name.into(),
            format,
            width,
            height,
            layers: 1,
            cube: false,
            usage,
        }
    }

    /// A cube image with square faces of `size` texels.
    pub fn cube(name: &str, format: vk::Format, size: u32, usage: vk::ImageUsageFlags) -> Self {
        ImageDesc {
            name: name.into(),
            format,
            width: size,
            height: size,
            layers: 6,
            cube: true,
            usage,
        }
    }

    /// Bytes of one tightly packed layer.
    pub fn layer_bytes(&self) -> VkResult<u64> {
        let texel = conv::format_texel_size(self.format).ok_or_else(|| VkError::Usage {
            what: self.name.clone(),
            detail: format!("no texel size known for format {:?}", self.format),
        })?;
        Ok(u64::from(self.width) * u64::from(self.height) * u64::from(texel))
    }

    pub(crate) fn aspect(&self) -> vk::ImageAspectFlags {
        match self.format {
            vk::Format::D32_SFLOAT | vk::Format::D16_UNORM => vk::ImageAspectFlags::DEPTH,
            _ => vk::ImageAspectFlags::COLOR,
        }
    }
}

/// An image, its memory and its views.
pub struct Image {
    device: Arc<Device>,
    raw: vk::Image,
    allocation: Option<Allocation>,
    desc: ImageDesc,
    view: vk::ImageView,
    array_view: vk::ImageView,
    layer_views: Vec<vk::ImageView>,
}

impl Image {
    /// Creates the image in device-local memory, with its views. Layout starts `UNDEFINED`.
    pub fn new(device: &Arc<Device>, desc: ImageDesc) -> VkResult<Self> {
        if desc.cube
            && (desc.layers == 0 || !desc.layers.is_multiple_of(6) || desc.width != desc.height)
        {
            return Err(VkError::Usage {
                what: desc.name.clone(),
                detail: "a cube image needs square faces and a multiple of 6 layers".into(),
            });
        }
        let name = desc.name.clone();
        let flags = if desc.cube {
            vk::ImageCreateFlags::CUBE_COMPATIBLE
        } else {
            vk::ImageCreateFlags::empty()
        };
        let info = vk::ImageCreateInfo::default()
            .flags(flags)
            .image_type(vk::ImageType::TYPE_2D)
            .format(desc.format)
            .extent(vk::Extent3D {
                width: desc.width,
                height: desc.height,
                depth: 1,
            })
            .mip_levels(1)
            .array_layers(desc.layers)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(desc.usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        // SAFETY: valid create info; destroyed in `Drop` (or below on failure).
        let raw = unsafe { device.raw.create_image(&info, None) }
            .map_err(call_err("vkCreateImage", &name))?;
        // SAFETY: `raw` is a live image of this device.
        let requirements = unsafe { device.raw.get_image_memory_requirements(raw) };
        let allocation = match device.allocator().allocate(&AllocationCreateDesc {
            name: &name,
            requirements,
            location: MemoryLocation::GpuOnly,
            linear: false,
            allocation_scheme: AllocationScheme::GpuAllocatorManaged,
        }) {
            Ok(a) => a,
            Err(e) => {
                // SAFETY: `raw` is unused and unbound.
                unsafe { device.raw.destroy_image(raw, None) };
                return Err(alloc_err(&name)(e));
            }
        };
        let mut image = Image {
            device: device.clone(),
            raw,
            allocation: Some(allocation),
            desc,
            view: vk::ImageView::null(),
            array_view: vk::ImageView::null(),
            layer_views: Vec::new(),
        };
        if let Some(a) = &image.allocation {
            // SAFETY: the allocation matches this image's requirements and outlives the binding.
            unsafe { device.raw.bind_image_memory(raw, a.memory(), a.offset()) }
                .map_err(call_err("vkBindImageMemory", &name))?;
        }
        device.set_name(raw, &name);
        let layers = image.desc.layers;
        let natural = match (image.desc.cube, layers) {
            (true, 6) => vk::ImageViewType::CUBE,
            (true, _) => vk::ImageViewType::CUBE_ARRAY,
            (false, 1) => vk::ImageViewType::TYPE_2D,
            (false, _) => vk::ImageViewType::TYPE_2D_ARRAY,
        };
        // Views are stored as soon as created so `Drop` destroys them if a later one fails.
        image.view = image.create_view(natural, 0, layers)?;
        image.array_view = image.create_view(vk::ImageViewType::TYPE_2D_ARRAY, 0, layers)?;
        for layer in 0..layers {
            let v = image.create_view(vk::ImageViewType::TYPE_2D, layer, 1)?;
            image.layer_views.push(v);
        }
        Ok(image)
    }

    fn create_view(
        &self,
        ty: vk::ImageViewType,
        base_layer: u32,
        count: u32,
    ) -> VkResult<vk::ImageView> {
        let info = vk::ImageViewCreateInfo::default()
            .image(self.raw)
            .view_type(ty)
            .format(self.desc.format)
            .subresource_range(self.range(base_layer, count));
        // SAFETY: the image is alive and bound; the range lies within it.
        unsafe { self.device.raw.create_image_view(&info, None) }
            .map_err(call_err("vkCreateImageView", &self.desc.name))
    }

    /// Subresource range of `count` layers from `base_layer` (mip 0).
    pub fn range(&self, base_layer: u32, count: u32) -> vk::ImageSubresourceRange {
        vk::ImageSubresourceRange::default()
            .aspect_mask(self.desc.aspect())
            .base_mip_level(0)
            .level_count(1)
            .base_array_layer(base_layer)
            .layer_count(count)
    }

    pub fn raw(&self) -> vk::Image {
        self.raw
    }
    pub fn desc(&self) -> &ImageDesc {
        &self.desc
    }
    /// Cube (array) view for cube images, else 2-D (array) view.
    pub fn view(&self) -> vk::ImageView {
        self.view
    }
    /// `2D_ARRAY` view over all layers.
    pub fn array_view(&self) -> vk::ImageView {
        self.array_view
    }
    /// `2D` view of one layer (face).
    pub fn layer_view(&self, layer: u32) -> Option<vk::ImageView> {
        self.layer_views.get(layer as usize).copied()
    }
}

impl Drop for Image {
    fn drop(&mut self) {
        for v in self
            .layer_views
            .drain(..)
            .chain([self.view, self.array_view])
        {
            if v != vk::ImageView::null() {
                // SAFETY: the view belongs to this image, is no longer used by the GPU, destroyed once.
                unsafe { self.device.raw.destroy_image_view(v, None) };
            }
        }
        // SAFETY: all views are gone; no GPU work uses the image any more.
        unsafe { self.device.raw.destroy_image(self.raw, None) };
        if let Some(a) = self.allocation.take()
            && let Err(e) = self.device.allocator().free(a)
        {
            log::error!("freeing memory of image `{}` failed: {e}", self.desc.name);
        }
    }
}
