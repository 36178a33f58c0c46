//! Physical device selection and the logical device, its queue and its memory allocator.
//!
//! Invariants:
//! - Selection: an explicit index if given; else the first usable discrete GPU; else the first
//!   usable device of any type (lavapipe). "Usable" is [`DeviceReport::missing_requirement`].
//! - Enabled features: the required ones (Vulkan 1.3 dynamic rendering and synchronization2) and
//!   the optional ones that are present (subgroup size control, full compute subgroups,
//!   fragment stores and atomics, host query reset). [`EnabledFeatures`] records which.
//! - [`Device`] holds an `Arc<Instance>`, and every resource holds an `Arc<Device>`, so Vulkan
//!   objects are destroyed children-first. `Drop` waits for idle, drops the allocator (freeing its
//!   memory blocks) and only then destroys the device.
use std::mem::ManuallyDrop;
use std::sync::{Arc, Mutex, MutexGuard};

use ash::vk;
use gpu_allocator::vulkan::{Allocator, AllocatorCreateDesc};

use super::error::{VkError, VkResult, call_err};
use super::info::{DeviceReport, probe_all};
use super::instance::Instance;

/// Optional features that were present and therefore enabled.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct EnabledFeatures {
    /// `subgroupSizeControl` (Vulkan 1.3 core; VK_EXT_subgroup_size_control).
    pub subgroup_size_control: bool,
    /// `computeFullSubgroups` (Vulkan 1.3 core; VK_EXT_subgroup_size_control).
    pub compute_full_subgroups: bool,
    /// `fragmentStoresAndAtomics` (Vulkan 1.0 optional): fragment-stage storage writes.
    pub fragment_stores_and_atomics: bool,
    /// `hostQueryReset` (Vulkan 1.2 core; VK_EXT_host_query_reset).
    pub host_query_reset: bool,
}

/// The logical device and what hangs off it.
pub struct Device {
    pub(crate) raw: ash::Device,
    pub(crate) physical: vk::PhysicalDevice,
    pub(crate) queue: vk::Queue,
    pub(crate) queue_family: u32,
    allocator: ManuallyDrop<Mutex<Allocator>>,
    /// Device-level debug-utils functions, when the instance enabled VK_EXT_debug_utils.
    pub(crate) debug_utils: Option<ash::ext::debug_utils::Device>,
    pub(crate) report: DeviceReport,
    pub(crate) enabled: EnabledFeatures,
    /// Kept last: the instance must outlive the device.
    pub(crate) instance: Arc<Instance>,
}

/// Picks a physical device; see the module docs for the order.
fn select(
    devices: &[(vk::PhysicalDevice, DeviceReport)],
    index: Option<usize>,
) -> VkResult<(vk::PhysicalDevice, DeviceReport)> {
    if devices.is_empty() {
        return Err(VkError::NoDriver {
            detail: "the Vulkan loader found no physical device".into(),
        });
    }
    let check = |(pd, r): &(vk::PhysicalDevice, DeviceReport)| match r.missing_requirement() {
        None => Ok((*pd, r.clone())),
        Some(feature) => Err(VkError::MissingFeature {
            device: r.name.clone(),
            feature,
        }),
    };
    if let Some(i) = index {
        let d = devices.get(i).ok_or(VkError::BadDeviceIndex {
            index: i,
            count: devices.len(),
        })?;
        return check(d);
    }
    let usable = |d: &&(vk::PhysicalDevice, DeviceReport)| d.1.missing_requirement().is_none();
    devices
        .iter()
        .filter(usable)
        .find(|d| d.1.device_type == vk::PhysicalDeviceType::DISCRETE_GPU)
        .or_else(|| devices.iter().find(usable))
        .map_or_else(|| check(&devices[0]), check)
}

impl Device {
    /// Selects a physical device and creates the logical device, queue and allocator.
    pub(crate) fn new(instance: Arc<Instance>, index: Option<usize>) -> VkResult<Self> {
        let devices = probe_all(&instance)?;
        let (physical, report) = select(&devices, index)?;
        let queue_family = report.queue_family.ok_or_else(|| VkError::MissingFeature {
            device: report.name.clone(),
            feature: "a queue family with graphics and compute".into(),
        })?;
        let enabled = EnabledFeatures {
            subgroup_size_control: report.subgroup_size_control.is_some(),
            compute_full_subgroups: report.compute_full_subgroups,
            fragment_stores_and_atomics: report.fragment_stores_and_atomics,
            host_query_reset: report.host_query_reset,
        };

        let priorities = [1.0f32];
        let queues = [vk::DeviceQueueCreateInfo::default()
            .queue_family_index(queue_family)
            .queue_priorities(&priorities)];
        let core = vk::PhysicalDeviceFeatures::default()
            .fragment_stores_and_atomics(enabled.fragment_stores_and_atomics);
        let mut v12 = vk::PhysicalDeviceVulkan12Features::default()
            .host_query_reset(enabled.host_query_reset);
        let mut v13 = vk::PhysicalDeviceVulkan13Features::default()
            .dynamic_rendering(true)
            .synchronization2(true)
            .subgroup_size_control(enabled.subgroup_size_control)
            .compute_full_subgroups(enabled.compute_full_subgroups);
        let mut features = vk::PhysicalDeviceFeatures2::default()
            .features(core)
            .push_next(&mut v12)
            .push_next(&mut v13);
        let info = vk::DeviceCreateInfo::default()
            .queue_create_infos(&queues)
            .push_next(&mut features);
        // SAFETY: `physical` came from this instance; only features it reports are enabled.
        let raw = unsafe { instance.raw.create_device(physical, &info, None) }
            .map_err(call_err("vkCreateDevice", report.name.clone()))?;
        // SAFETY: one queue was requested from `queue_family`.
        let queue = unsafe { raw.get_device_queue(queue_family, 0) };

        let allocator = Allocator::new(&AllocatorCreateDesc {
            instance: instance.raw.clone(),
            device: raw.clone(),
            physical_device: physical,
            debug_settings: Default::default(),
            buffer_device_address: false,
            allocation_sizes: Default::default(),
        });
        let allocator = match allocator {
            Ok(a) => a,
            Err(source) => {
                // SAFETY: nothing was created from the device yet.
                unsafe { raw.destroy_device(None) };
                return Err(VkError::Alloc {
                    what: "allocator".into(),
                    error: source,
                });
            }
        };
        let debug_utils = instance
            .debug_utils
            .then(|| ash::ext::debug_utils::Device::new(&instance.raw, &raw));
        log::info!("Vulkan device: {} ({:?})", report.name, report.driver_name);
        Ok(Device {
            raw,
            physical,
            queue,
            queue_family,
            allocator: ManuallyDrop::new(Mutex::new(allocator)),
            debug_utils,
            report,
            enabled,
            instance,
        })
    }

    /// Locks the allocator. A poisoned lock is still usable: the allocator has no invariant a
    /// panicking holder could have broken halfway that matters more than freeing memory.
    pub(crate) fn allocator(&self) -> MutexGuard<'_, Allocator> {
        self.allocator.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Names a Vulkan object for validation messages and debuggers (no-op without debug utils).
    pub(crate) fn set_name<H: vk::Handle>(&self, handle: H, name: &str) {
        let Some(du) = &self.debug_utils else { return };
        let Ok(name) = std::ffi::CString::new(name) else {
            return;
        };
        let info = vk::DebugUtilsObjectNameInfoEXT::default()
            .object_handle(handle)
            .object_name(&name);
        // SAFETY: `handle` is a live object of this device; the name outlives the call.
        if let Err(e) = unsafe { du.set_debug_utils_object_name(&info) } {
            log::warn!(
                "cannot name Vulkan object `{}`: {e}",
                name.to_string_lossy()
            );
        }
    }

    /// The physical device (for format and property queries).
    pub fn physical(&self) -> vk::PhysicalDevice {
        self.physical
    }

    /// The probed report of this device.
    pub fn report(&self) -> &DeviceReport {
        &self.report
    }

    /// Optional features that are enabled.
    pub fn enabled_features(&self) -> EnabledFeatures {
        self.enabled
    }
}

impl Drop for Device {
    fn drop(&mut self) {
        // SAFETY: the device is alive; waiting makes every submitted command finish first.
        if let Err(e) = unsafe { self.raw.device_wait_idle() } {
            log::error!("vkDeviceWaitIdle before destruction failed: {e}");
        }
        // SAFETY: dropped exactly once, here; every allocation was freed by its owner, which held
        // an `Arc<Device>`.
        unsafe { ManuallyDrop::drop(&mut self.allocator) };
        // SAFETY: every child object is gone (children hold `Arc<Device>`), and the allocator's
        // memory blocks were freed just above.
        unsafe { self.raw.destroy_device(None) };
    }
}
