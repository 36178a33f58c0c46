//! Probing physical devices into plain data ([`DeviceReport`]), as used for device selection,
//! feature enabling and `cubetrace info`.
//!
//! Invariants: probing only reads properties and features; Vulkan 1.2 / 1.3 property structs are
//! queried only on devices whose API version has them, so their fields are `None` otherwise.
use std::fmt;

use ash::vk;

use super::conv;
use super::error::{VkResult, call_err};
use super::instance::Instance;

/// Subgroup operations cubetrace's compute passes need (ballot, vote, arithmetic).
pub const REQUIRED_SUBGROUP_OPS: vk::SubgroupFeatureFlags = vk::SubgroupFeatureFlags::from_raw(
    vk::SubgroupFeatureFlags::BASIC.as_raw()
        | vk::SubgroupFeatureFlags::VOTE.as_raw()
        | vk::SubgroupFeatureFlags::ARITHMETIC.as_raw()
        | vk::SubgroupFeatureFlags::BALLOT.as_raw(),
);

/// Everything cubetrace wants to know about one physical device. Plain data.
#[derive(Clone, Debug, PartialEq)]
pub struct DeviceReport {
    /// Index in `vkEnumeratePhysicalDevices` order (the `--device N` number).
    pub index: usize,
    pub name: String,
    pub device_type: vk::PhysicalDeviceType,
    /// `(major, minor, patch)` of the device's Vulkan API version.
    pub api_version: (u32, u32, u32),
    /// `VkPhysicalDeviceVulkan12Properties::driverName` / `driverInfo` (Vulkan 1.2+).
    pub driver_name: Option<String>,
    pub driver_info: Option<String>,
    /// Default subgroup size (Vulkan 1.1 subgroup properties).
    pub subgroup_size: u32,
    pub subgroup_stages: vk::ShaderStageFlags,
    pub subgroup_ops: vk::SubgroupFeatureFlags,
    /// `(minSubgroupSize, maxSubgroupSize)` when the `subgroupSizeControl` feature is present
    /// (Vulkan 1.3 core, from VK_EXT_subgroup_size_control).
    pub subgroup_size_control: Option<(u32, u32)>,
    /// `computeFullSubgroups` (Vulkan 1.3 core).
    pub compute_full_subgroups: bool,
    /// `dynamicRendering` (Vulkan 1.3 core, from VK_KHR_dynamic_rendering).
    pub dynamic_rendering: bool,
    /// `synchronization2` (Vulkan 1.3 core, from VK_KHR_synchronization2).
    pub synchronization2: bool,
    /// `fragmentStoresAndAtomics` (Vulkan 1.0 optional feature).
    pub fragment_stores_and_atomics: bool,
    /// `hostQueryReset` (Vulkan 1.2 core).
    pub host_query_reset: bool,
    /// `timestampComputeAndGraphics`.
    pub timestamp_compute_and_graphics: bool,
    /// Nanoseconds per timestamp tick.
    pub timestamp_period_ns: f32,
    /// `timestampValidBits` of the chosen queue family (0: no timestamps there).
    pub timestamp_valid_bits: u32,
    /// A queue family supporting graphics and compute, if any.
    pub queue_family: Option<u32>,
    pub max_image_dimension_cube: u32,
    pub max_compute_work_group_invocations: u32,
    /// `maxComputeWorkgroupSubgroups` (Vulkan 1.3).
    pub max_compute_workgroup_subgroups: Option<u32>,
    pub max_storage_buffer_range: u32,
    pub max_uniform_buffer_range: u32,
    pub max_compute_shared_memory_size: u32,
}

impl DeviceReport {
    /// Whether timestamps can be written on the chosen queue family.
    pub fn timestamps_supported(&self) -> bool {
        self.timestamp_compute_and_graphics && self.timestamp_valid_bits > 0
    }

    /// The first required capability this device lacks, by name; `None` if it has them all.
    pub fn missing_requirement(&self) -> Option<String> {
        if self.api_version < (1, 3, 0) {
            return Some("Vulkan 1.3".into());
        }
        if self.queue_family.is_none() {
            return Some("a queue family with graphics and compute".into());
        }
        if !self.dynamic_rendering {
            return Some("dynamicRendering".into());
        }
        if !self.synchronization2 {
            return Some("synchronization2".into());
        }
        if !self.subgroup_stages.contains(vk::ShaderStageFlags::COMPUTE) {
            return Some("subgroup operations in compute shaders".into());
        }
        if !self.subgroup_ops.contains(REQUIRED_SUBGROUP_OPS) {
            let missing = conv::subgroup_ops_names(REQUIRED_SUBGROUP_OPS & !self.subgroup_ops);
            return Some(format!("subgroup operations: {}", missing.join(", ")));
        }
        None
    }
}

impl fmt::Display for DeviceReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let (ma, mi, pa) = self.api_version;
        writeln!(
            f,
            "device {}: {} ({})",
            self.index,
            self.name,
            conv::device_type_name(self.device_type)
        )?;
        writeln!(
            f,
            "  driver: {} {}",
            self.driver_name.as_deref().unwrap_or("?"),
            self.driver_info.as_deref().unwrap_or("")
        )?;
        writeln!(f, "  Vulkan API: {ma}.{mi}.{pa}")?;
        write!(f, "  subgroups: size {}", self.subgroup_size)?;
        if let Some((lo, hi)) = self.subgroup_size_control {
            write!(f, " (size control {lo}..={hi})")?;
        }
        writeln!(
            f,
            "; ops [{}] in [{}]",
            conv::subgroup_ops_names(self.subgroup_ops).join(", "),
            conv::stage_names(self.subgroup_stages).join(", ")
        )?;
        writeln!(
            f,
            "  features: dynamicRendering {}, synchronization2 {}, fragmentStoresAndAtomics {}, computeFullSubgroups {}",
            self.dynamic_rendering,
            self.synchronization2,
            self.fragment_stores_and_atomics,
            self.compute_full_subgroups
        )?;
        writeln!(
            f,
            "  limits: cube {} px, workgroup {} invocations / {} subgroups, shared memory {} KiB, storage buffer range {} MiB",
            self.max_image_dimension_cube,
            self.max_compute_work_group_invocations,
            self.max_compute_workgroup_subgroups
                .map_or("?".to_string(), |v| v.to_string()),
            self.max_compute_shared_memory_size / 1024,
            self.max_storage_buffer_range / (1024 * 1024)
        )?;
        if self.timestamps_supported() {
            writeln!(
                f,
                "  timestamps: yes ({} ns/tick, {} valid bits)",
                self.timestamp_period_ns, self.timestamp_valid_bits
            )?;
        } else {
            writeln!(f, "  timestamps: no")?;
        }
        match self.missing_requirement() {
            None => write!(f, "  usable by cubetrace: yes"),
            Some(m) => write!(f, "  usable by cubetrace: no (lacks {m})"),
        }
    }
}

/// Probes one physical device.
pub(crate) fn probe(instance: &Instance, index: usize, pd: vk::PhysicalDevice) -> DeviceReport {
    let raw = &instance.raw;
    // SAFETY: `pd` was enumerated from this instance.
    let props = unsafe { raw.get_physical_device_properties(pd) };
    let api = props.api_version;
    let api_version = (
        vk::api_version_major(api),
        vk::api_version_minor(api),
        vk::api_version_patch(api),
    );

    let mut v11 = vk::PhysicalDeviceVulkan11Properties::default();
    let mut p2 = vk::PhysicalDeviceProperties2::default().push_next(&mut v11);
    // SAFETY: `pd` is valid; the chain holds a 1.1 struct, core on every 1.1+ device (our instance is 1.3).
    unsafe { raw.get_physical_device_properties2(pd, &mut p2) };
    let (driver_name, driver_info) = if api_version >= (1, 2, 0) {
        let mut v12 = vk::PhysicalDeviceVulkan12Properties::default();
        let mut p2 = vk::PhysicalDeviceProperties2::default().push_next(&mut v12);
        // SAFETY: the device reports API 1.2+, so the 1.2 property struct is valid in the chain.
        unsafe { raw.get_physical_device_properties2(pd, &mut p2) };
        let s = |r: Result<&std::ffi::CStr, _>| {
            r.ok()
                .map(|c: &std::ffi::CStr| c.to_string_lossy().into_owned())
        };
        (s(v12.driver_name_as_c_str()), s(v12.driver_info_as_c_str()))
    } else {
        (None, None)
    };
    let mut f = DeviceReport {
        index,
        name: props
            .device_name_as_c_str()
            .map(|c| c.to_string_lossy().into_owned())
            .unwrap_or_default(),
        device_type: props.device_type,
        api_version,
        driver_name,
        driver_info,
        subgroup_size: v11.subgroup_size,
        subgroup_stages: v11.subgroup_supported_stages,
        subgroup_ops: v11.subgroup_supported_operations,
        subgroup_size_control: None,
        compute_full_subgroups: false,
        dynamic_rendering: false,
        synchronization2: false,
        fragment_stores_and_atomics: false,
        host_query_reset: false,
        timestamp_compute_and_graphics: props.limits.timestamp_compute_and_graphics == vk::TRUE,
        timestamp_period_ns: props.limits.timestamp_period,
        timestamp_valid_bits: 0,
        queue_family: None,
        max_image_dimension_cube: props.limits.max_image_dimension_cube,
        max_compute_work_group_invocations: props.limits.max_compute_work_group_invocations,
        max_compute_workgroup_subgroups: None,
        max_storage_buffer_range: props.limits.max_storage_buffer_range,
        max_uniform_buffer_range: props.limits.max_uniform_buffer_range,
        max_compute_shared_memory_size: props.limits.max_compute_shared_memory_size,
    };

    // SAFETY: `pd` is valid.
    let core = unsafe { raw.get_physical_device_features(pd) };
    f.fragment_stores_and_atomics = core.fragment_stores_and_atomics == vk::TRUE;
    if api_version >= (1, 2, 0) {
        let mut v12 = vk::PhysicalDeviceVulkan12Features::default();
        let mut f2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut v12);
        // SAFETY: the device reports API 1.2+.
        unsafe { raw.get_physical_device_features2(pd, &mut f2) };
        f.host_query_reset = v12.host_query_reset == vk::TRUE;
    }
    if api_version >= (1, 3, 0) {
        let mut v13f = vk::PhysicalDeviceVulkan13Features::default();
        let mut f2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut v13f);
        // SAFETY: the device reports API 1.3+.
        unsafe { raw.get_physical_device_features2(pd, &mut f2) };
        let mut v13p = vk::PhysicalDeviceVulkan13Properties::default();
        let mut p2 = vk::PhysicalDeviceProperties2::default().push_next(&mut v13p);
        // SAFETY: the device reports API 1.3+.
        unsafe { raw.get_physical_device_properties2(pd, &mut p2) };
        f.dynamic_rendering = v13f.dynamic_rendering == vk::TRUE;
        f.synchronization2 = v13f.synchronization2 == vk::TRUE;
        f.compute_full_subgroups = v13f.compute_full_subgroups == vk::TRUE;
        if v13f.subgroup_size_control == vk::TRUE {
            f.subgroup_size_control = Some((v13p.min_subgroup_size, v13p.max_subgroup_size));
        }
        f.max_compute_workgroup_subgroups = Some(v13p.max_compute_workgroup_subgroups);
    }

    // SAFETY: `pd` is valid.
    let families = unsafe { raw.get_physical_device_queue_family_properties(pd) };
    let want = vk::QueueFlags::GRAPHICS | vk::QueueFlags::COMPUTE;
    if let Some((i, fam)) = families
        .iter()
        .enumerate()
        .find(|(_, q)| q.queue_flags.contains(want))
    {
        f.queue_family = Some(i as u32);
        f.timestamp_valid_bits = fam.timestamp_valid_bits;
    }
    f
}

/// Probes every physical device, in enumeration order.
pub(crate) fn probe_all(instance: &Instance) -> VkResult<Vec<(vk::PhysicalDevice, DeviceReport)>> {
    // SAFETY: the instance is alive.
    let pds = unsafe { instance.raw.enumerate_physical_devices() }
        .map_err(call_err("vkEnumeratePhysicalDevices", "instance"))?;
    Ok(pds
        .into_iter()
        .enumerate()
        .map(|(i, pd)| (pd, probe(instance, i, pd)))
        .collect())
}
