//! Pipelines and descriptor sets built from the reflected shader table.
//!
//! Invariants:
//! - Descriptor set layouts come from [`EntryPoint::bindings`](super::shaders::EntryPoint), never
//!   from a hand-written list: set `g` holds exactly the bindings of `@group(g)`, visible to the
//!   stages of the entry points that use them. Groups with no binding get an empty layout.
//! - A [`BindGroup`] must supply every reflected binding of its group with a resource of the
//!   matching kind (and a buffer at least `min_size` bytes); otherwise creation fails, naming the
//!   pass and the WGSL variable.
//! - Graphics pipelines ([`super::graphics`]) use the same layout builder with vertex + fragment
//!   entry points, and dynamic rendering (no render pass objects).
use std::collections::BTreeMap;
use std::sync::Arc;

use ash::vk;

use super::buffer::Buffer;
use super::context::{GpuContext, Recorder};
use super::conv;
use super::device::Device;
use super::error::{VkError, VkResult, call_err};
use super::image::Image;
use super::shaders::{Binding, BindingKind, EntryPoint, Pass, Stage};

/// Set layouts and the pipeline layout for some entry points of a pass.
pub struct PipelineLayout {
    device: Arc<Device>,
    pub(crate) sets: Vec<vk::DescriptorSetLayout>,
    pub(crate) raw: vk::PipelineLayout,
    /// `group -> bindings` as reflected.
    pub(crate) groups: BTreeMap<u32, Vec<Binding>>,
}

impl PipelineLayout {
    /// Builds set layouts and the pipeline layout from the reflected bindings of `entries`.
    pub fn from_reflection(
        device: &Arc<Device>,
        pass: &Pass,
        entries: &[&EntryPoint],
    ) -> VkResult<Self> {
        let mut groups: BTreeMap<u32, Vec<Binding>> = BTreeMap::new();
        let mut stages: BTreeMap<(u32, u32), vk::ShaderStageFlags> = BTreeMap::new();
        for e in entries {
            for b in e.bindings {
                *stages.entry((b.group, b.binding)).or_default() |= conv::shader_stage(e.stage);
                let g = groups.entry(b.group).or_default();
                if !g.iter().any(|x| x.binding == b.binding) {
                    g.push(*b);
                }
            }
        }
        let mut layout = PipelineLayout {
            device: device.clone(),
            sets: Vec::new(),
            raw: vk::PipelineLayout::null(),
            groups,
        };
        let count = layout.groups.keys().next_back().map_or(0, |g| g + 1);
        for g in 0..count {
            let empty = Vec::new();
            let bindings: Vec<vk::DescriptorSetLayoutBinding> = layout
                .groups
                .get(&g)
                .unwrap_or(&empty)
                .iter()
                .map(|b| {
                    vk::DescriptorSetLayoutBinding::default()
                        .binding(b.binding)
                        .descriptor_type(conv::descriptor_type(b.kind))
                        .descriptor_count(1)
                        .stage_flags(
                            stages
                                .get(&(b.group, b.binding))
                                .copied()
                                .unwrap_or_default(),
                        )
                })
                .collect();
            let info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&bindings);
            // SAFETY: the bindings are unique per set (deduplicated above).
            let set = unsafe { device.raw.create_descriptor_set_layout(&info, None) }
                .map_err(call_err("vkCreateDescriptorSetLayout", pass.name))?;
            layout.sets.push(set);
        }
        let info = vk::PipelineLayoutCreateInfo::default().set_layouts(&layout.sets);
        // SAFETY: every set layout is alive.
        layout.raw = unsafe { device.raw.create_pipeline_layout(&info, None) }
            .map_err(call_err("vkCreatePipelineLayout", pass.name))?;
        device.set_name(layout.raw, pass.name);
        Ok(layout)
    }
}

impl Drop for PipelineLayout {
    fn drop(&mut self) {
        if self.raw != vk::PipelineLayout::null() {
            // SAFETY: no pipeline using it is in flight (owners wait before dropping).
            unsafe { self.device.raw.destroy_pipeline_layout(self.raw, None) };
        }
        for s in self.sets.drain(..) {
            // SAFETY: as above; each layout destroyed once.
            unsafe { self.device.raw.destroy_descriptor_set_layout(s, None) };
        }
    }
}

/// Creates a shader module from a pass's SPIR-V. The caller destroys it.
pub(crate) fn shader_module(device: &Device, pass: &Pass) -> VkResult<vk::ShaderModule> {
    let info = vk::ShaderModuleCreateInfo::default().code(pass.spirv);
    // SAFETY: `spirv` is naga-validated SPIR-V 1.3 as `u32` words.
    let module = unsafe { device.raw.create_shader_module(&info, None) }
        .map_err(call_err("vkCreateShaderModule", pass.name))?;
    device.set_name(module, pass.name);
    Ok(module)
}

/// Workgroups per dispatch row: the smallest `maxComputeWorkGroupCount[0]` Vulkan guarantees.
pub const MAX_GROUPS_X: u32 = 65_535;

/// The workgroup counts of a dispatch of `invocations` lanes in workgroups of `workgroup`, laid
/// in rows of at most `max_x` (at least 1) workgroups; at least one workgroup. The shader
/// linearises `(x, y)`.
pub fn dispatch_rows(invocations: u32, workgroup: u32, max_x: u32) -> [u32; 3] {
    let groups = invocations.div_ceil(workgroup).max(1);
    let x = groups.min(max_x.max(1));
    [x, groups.div_ceil(x), 1]
}

/// Options for [`ComputePipeline::new`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ComputeOptions {
    /// Require this subgroup size (needs `subgroupSizeControl` and a size within min..=max; on
    /// lavapipe only the native size validates). Ignored with a log line when unsupported.
    pub required_subgroup_size: Option<u32>,
}

/// A compute pipeline for one entry point of a pass.
pub struct ComputePipeline {
    pub pass: &'static Pass,
    pub entry: &'static EntryPoint,
    raw: vk::Pipeline,
    /// Dropped after `raw` (field order after `Drop::drop`).
    pub(crate) layout: PipelineLayout,
    device: Arc<Device>,
}

impl ComputePipeline {
    /// Builds the pipeline for `entry_point` of `pass`, with reflected descriptor set layouts.
    pub fn new(
        ctx: &GpuContext,
        pass: &'static Pass,
        entry_point: &str,
        options: ComputeOptions,
    ) -> VkResult<Self> {
        let device = ctx.device();
        let entry = pass
            .entry_point(entry_point)
            .filter(|e| e.stage == Stage::Compute)
            .ok_or_else(|| VkError::Shader {
                pass: pass.name.into(),
                detail: format!("no compute entry point `{entry_point}`"),
            })?;
        let layout = PipelineLayout::from_reflection(device, pass, &[entry])?;
        let module = shader_module(device, pass)?;
        let name = std::ffi::CString::new(entry.name).map_err(|_| VkError::Shader {
            pass: pass.name.into(),
            detail: "entry point name contains NUL".into(),
        })?;
        let mut required = vk::PipelineShaderStageRequiredSubgroupSizeCreateInfo::default();
        let mut stage = vk::PipelineShaderStageCreateInfo::default()
            .stage(vk::ShaderStageFlags::COMPUTE)
            .module(module)
            .name(&name);
        if let Some(size) = options.required_subgroup_size {
            match device.report.subgroup_size_control {
                Some((lo, hi))
                    if device.enabled.subgroup_size_control && (lo..=hi).contains(&size) =>
                {
                    required = required.required_subgroup_size(size);
                    stage = stage.push_next(&mut required);
                }
                _ => log::info!(
                    "{}: subgroup size {size} cannot be required on this device; using the default",
                    pass.name
                ),
            }
        }
        let info = [vk::ComputePipelineCreateInfo::default()
            .stage(stage)
            .layout(layout.raw)];
        // SAFETY: module, layout and entry name are alive; the layout was reflected from this module.
        let created = unsafe {
            device
                .raw
                .create_compute_pipelines(vk::PipelineCache::null(), &info, None)
        };
        // SAFETY: pipeline creation is done with the module (success or not).
        unsafe { device.raw.destroy_shader_module(module, None) };
        let raw = created.map_err(|(_, e)| call_err("vkCreateComputePipelines", pass.name)(e))?[0];
        device.set_name(raw, pass.name);
        Ok(ComputePipeline {
            pass,
            entry,
            raw,
            layout,
            device: device.clone(),
        })
    }

    /// The Vulkan handle.
    pub fn raw(&self) -> vk::Pipeline {
        self.raw
    }

    /// Creates descriptor set `group` with `resources` given as `(binding, resource)`.
    pub fn bind_group(&self, group: u32, resources: &[(u32, Resource<'_>)]) -> VkResult<BindGroup> {
        BindGroup::new(&self.device, self.pass, &self.layout, group, resources)
    }

    /// Records bind + dispatch of `groups` workgroups. `sets` must be consecutive groups, starting
    /// at `sets[0]`'s group.
    pub fn dispatch(&self, rec: &Recorder<'_>, sets: &[&BindGroup], groups: [u32; 3]) {
        self.bind(rec, sets);
        // SAFETY: pipeline and sets are bound.
        unsafe {
            self.device
                .raw
                .cmd_dispatch(rec.cmd, groups[0], groups[1], groups[2])
        };
    }

    /// Records bind + an indirect dispatch whose workgroup counts are the
    /// `VkDispatchIndirectCommand` (three u32) at byte `offset` of `args`, written by an earlier
    /// pass (the caller records the barrier to `DRAW_INDIRECT`/`INDIRECT_COMMAND_READ`). Fails
    /// when `args` lacks `INDIRECT_BUFFER` usage, is too small, or `offset` is not 4-aligned.
    pub fn dispatch_indirect(
        &self,
        rec: &Recorder<'_>,
        sets: &[&BindGroup],
        args: &Buffer,
        offset: u64,
    ) -> VkResult<()> {
        if !args.usage().contains(vk::BufferUsageFlags::INDIRECT_BUFFER)
            || !offset.is_multiple_of(4)
            || offset + 12 > args.size()
        {
            return Err(VkError::Usage {
                what: self.pass.name.into(),
                detail: format!(
                    "indirect dispatch from `{}` at byte {offset}: needs INDIRECT_BUFFER usage, a \
                     4-aligned offset and 12 bytes",
                    args.name()
                ),
            });
        }
        self.bind(rec, sets);
        // SAFETY: pipeline and sets are bound; `args` is an indirect buffer holding 12 bytes at a
        // 4-aligned `offset` (checked above) and is alive for the submission.
        unsafe {
            self.device
                .raw
                .cmd_dispatch_indirect(rec.cmd, args.raw(), offset)
        };
        Ok(())
    }

    fn bind(&self, rec: &Recorder<'_>, sets: &[&BindGroup]) {
        let raw_sets: Vec<vk::DescriptorSet> = sets.iter().map(|s| s.set).collect();
        // SAFETY: `rec` is recording; the pipeline is alive for the submission.
        unsafe {
            self.device
                .raw
                .cmd_bind_pipeline(rec.cmd, vk::PipelineBindPoint::COMPUTE, self.raw)
        };
        if !raw_sets.is_empty() {
            // SAFETY: the sets were allocated with this pipeline's set layouts, in group order.
            unsafe {
                self.device.raw.cmd_bind_descriptor_sets(
                    rec.cmd,
                    vk::PipelineBindPoint::COMPUTE,
                    self.layout.raw,
                    sets[0].group,
                    &raw_sets,
                    &[],
                )
            };
        }
    }
}

impl Drop for ComputePipeline {
    fn drop(&mut self) {
        // SAFETY: no submission using the pipeline is pending (submissions are waited on).
        unsafe { self.device.raw.destroy_pipeline(self.raw, None) };
    }
}

/// A resource bound to one reflected binding.
#[derive(Clone, Copy)]
pub enum Resource<'a> {
    /// Uniform or storage buffer (whole buffer).
    Buffer(&'a Buffer),
    /// Sampled image view in `layout`.
    Texture {
        view: vk::ImageView,
        layout: vk::ImageLayout,
    },
    /// Storage image view (in `GENERAL` layout).
    StorageTexture(vk::ImageView),
    Sampler(vk::Sampler),
}

impl Resource<'_> {
    /// `image` sampled in `SHADER_READ_ONLY_OPTIMAL`, where every pass leaves what it wrote.
    pub fn sampled(image: &Image) -> Resource<'_> {
        Resource::Texture {
            view: image.view(),
            layout: vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL,
        }
    }
}

/// One descriptor set, with its own small pool.
pub struct BindGroup {
    device: Arc<Device>,
    pool: vk::DescriptorPool,
    set: vk::DescriptorSet,
    group: u32,
}

impl BindGroup {
    pub(crate) fn new(
        device: &Arc<Device>,
        pass: &Pass,
        layout: &PipelineLayout,
        group: u32,
        resources: &[(u32, Resource<'_>)],
    ) -> VkResult<Self> {
        let err = |detail: String| VkError::Shader {
            pass: pass.name.into(),
            detail,
        };
        let set_layout = *layout
            .sets
            .get(group as usize)
            .ok_or_else(|| err(format!("no @group({group})")))?;
        let empty = Vec::new();
        let reflected = layout.groups.get(&group).unwrap_or(&empty);
        check_resources(device, pass, group, reflected, resources)?;
        let bg = Self::allocate(device, pass, set_layout, group, reflected)?;
        bg.write(reflected, resources);
        Ok(bg)
    }

    /// An empty set of `set_layout` in a pool sized for the reflected bindings.
    fn allocate(
        device: &Arc<Device>,
        pass: &Pass,
        set_layout: vk::DescriptorSetLayout,
        group: u32,
        reflected: &[Binding],
    ) -> VkResult<Self> {
        let mut counts: BTreeMap<i32, u32> = BTreeMap::new();
        for b in reflected {
            *counts
                .entry(conv::descriptor_type(b.kind).as_raw())
                .or_default() += 1;
        }
        let sizes: Vec<vk::DescriptorPoolSize> = counts
            .iter()
            .map(|(t, n)| vk::DescriptorPoolSize {
                ty: vk::DescriptorType::from_raw(*t),
                descriptor_count: *n,
            })
            .collect();
        let info = vk::DescriptorPoolCreateInfo::default()
            .max_sets(1)
            .pool_sizes(&sizes);
        // SAFETY: valid create info.
        let pool = unsafe { device.raw.create_descriptor_pool(&info, None) }
            .map_err(call_err("vkCreateDescriptorPool", pass.name))?;
        let mut bg = BindGroup {
            device: device.clone(),
            pool,
            set: vk::DescriptorSet::null(),
            group,
        };
        let layouts = [set_layout];
        let alloc = vk::DescriptorSetAllocateInfo::default()
            .descriptor_pool(pool)
            .set_layouts(&layouts);
        // SAFETY: the pool was sized for exactly this layout.
        bg.set = unsafe { device.raw.allocate_descriptor_sets(&alloc) }
            .map_err(call_err("vkAllocateDescriptorSets", pass.name))?[0];

        Ok(bg)
    }

    /// Writes `resources` (checked by [`check_resources`]) into the set.
    fn write(&self, reflected: &[Binding], resources: &[(u32, Resource<'_>)]) {
        let mut buffer_infos = Vec::new();
        let mut image_infos = Vec::new();
        for b in reflected {
            let Some((_, r)) = resources.iter().find(|(i, _)| *i == b.binding) else {
                continue;
            };
            match r {
                Resource::Buffer(buf) => buffer_infos.push((
                    b,
                    [vk::DescriptorBufferInfo::default()
                        .buffer(buf.raw())
                        .range(vk::WHOLE_SIZE)],
                )),
                Resource::Texture { view, layout } => image_infos.push((
                    b,
                    [vk::DescriptorImageInfo::default()
                        .image_view(*view)
                        .image_layout(*layout)],
                )),
                Resource::StorageTexture(view) => image_infos.push((
                    b,
                    [vk::DescriptorImageInfo::default()
                        .image_view(*view)
                        .image_layout(vk::ImageLayout::GENERAL)],
                )),
                Resource::Sampler(s) => {
                    image_infos.push((b, [vk::DescriptorImageInfo::default().sampler(*s)]))
                }
            }
        }
        let mut writes = Vec::new();
        for (b, info) in &buffer_infos {
            writes.push(
                vk::WriteDescriptorSet::default()
                    .dst_set(self.set)
                    .dst_binding(b.binding)
                    .descriptor_type(conv::descriptor_type(b.kind))
                    .buffer_info(info),
            );
        }
        for (b, info) in &image_infos {
            writes.push(
                vk::WriteDescriptorSet::default()
                    .dst_set(self.set)
                    .dst_binding(b.binding)
                    .descriptor_type(conv::descriptor_type(b.kind))
                    .image_info(info),
            );
        }
        // SAFETY: every write targets a binding of this set with its reflected type; resources are alive.
        unsafe { self.device.raw.update_descriptor_sets(&writes, &[]) };
    }
}

/// Refuses resources that do not match the reflected bindings of `@group(group)`: a missing or
/// extra binding, a kind the shader does not declare, a buffer smaller than the shader's type or
/// larger than the device can bind.
fn check_resources(
    device: &Device,
    pass: &Pass,
    group: u32,
    reflected: &[Binding],
    resources: &[(u32, Resource<'_>)],
) -> VkResult<()> {
    let err = |detail: String| VkError::Shader {
        pass: pass.name.into(),
        detail,
    };
    for b in reflected {
        let Some((_, r)) = resources.iter().find(|(i, _)| *i == b.binding) else {
            return Err(err(format!(
                "binding `{}` (@group({group}) @binding({})) not supplied",
                b.name, b.binding
            )));
        };
        let ok = match (b.kind, r) {
            (
                BindingKind::UniformBuffer | BindingKind::StorageBuffer { .. },
                Resource::Buffer(buf),
            ) => {
                if buf.size() < u64::from(b.min_size) {
                    return Err(err(format!(
                        "buffer `{}` ({} bytes) is smaller than `{}` needs ({} bytes)",
                        buf.name(),
                        buf.size(),
                        b.name,
                        b.min_size
                    )));
                }
                // Whole buffers are bound: the device's range limit applies to the size.
                let (limit, limit_name) = match b.kind {
                    BindingKind::UniformBuffer => (
                        device.report.max_uniform_buffer_range,
                        "maxUniformBufferRange",
                    ),
                    _ => (
                        device.report.max_storage_buffer_range,
                        "maxStorageBufferRange",
                    ),
                };
                if buf.size() > u64::from(limit) {
                    return Err(VkError::Limit {
                        device: device.report.name.clone(),
                        what: format!("buffer `{}` ({} MiB)", buf.name(), buf.size() >> 20),
                        limit: format!("{limit_name} = {} MiB", limit >> 20),
                    });
                }
                true
            }
            (BindingKind::SampledTexture { .. }, Resource::Texture { .. })
            | (BindingKind::StorageTexture { .. }, Resource::StorageTexture(_))
            | (BindingKind::Sampler { .. }, Resource::Sampler(_)) => true,
            _ => false,
        };
        if !ok {
            return Err(err(format!("binding `{}` expects {:?}", b.name, b.kind)));
        }
    }
    if let Some((i, _)) = resources
        .iter()
        .find(|(i, _)| !reflected.iter().any(|b| b.binding == *i))
    {
        return Err(err(format!(
            "@group({group}) @binding({i}) is not used by the shader"
        )));
    }

    Ok(())
}

impl BindGroup {
    /// The Vulkan descriptor set.
    pub(crate) fn raw(&self) -> vk::DescriptorSet {
        self.set
    }

    /// The `@group` index this set is for.
    pub(crate) fn group(&self) -> u32 {
        self.group
    }
}

impl Drop for BindGroup {
    fn drop(&mut self) {
        // SAFETY: destroying the pool frees its set; no pending submission uses it.
        unsafe { self.device.raw.destroy_descriptor_pool(self.pool, None) };
    }
}
