//! The environment the Vulkan loader sees: keeping a successful run free of "error" lines.
//!
//! **Where `error: XDG_RUNTIME_DIR is invalid or not set in the environment.` comes from.**
//! Every Mesa install registers an implicit Vulkan layer, `VK_LAYER_MESA_device_select`
//! (`/usr/share/vulkan/implicit_layer.d/VkLayer_MESA_device_select.json`), which the loader
//! puts in front of every application. When the application enumerates physical devices the
//! layer chooses a default GPU; if the instance enabled `VK_KHR_wayland_surface` — and wgpu
//! enables it whenever the driver offers it, window or not — the layer asks the Wayland
//! compositor which GPU it runs on by calling `wl_display_connect(NULL)`. libwayland resolves
//! the socket `$XDG_RUNTIME_DIR/$WAYLAND_DISPLAY`, and when `XDG_RUNTIME_DIR` is unset (CI,
//! plain `ssh`, containers) it prints that line to stderr and returns no connection. wgpu
//! enumerates twice (count, then fill), so the line appears twice, and the run goes on to
//! succeed on llvmpipe.
//!
//! No compositor can be reached in that case anyway, so the layer has nothing to ask it:
//! [`quiet_vulkan_probe`] then turns the layer off for this process with the switch its manifest
//! declares (`NODEVICE_SELECT=1`). The layer's other inputs are lost with it only where they
//! could not have mattered much: with several GPUs and an X server but no `XDG_RUNTIME_DIR`,
//! wgpu's own choice (high-performance adapter first; `WGPU_ADAPTER_NAME` to pick one) decides
//! instead of the X server's GPU. A user who asks the layer for a device (`MESA_VK_DEVICE_SELECT`,
//! `DRI_PRIME`) or sets `NODEVICE_SELECT` themselves keeps it as asked.
//!
//! Entry points: [`quiet_vulkan_probe`] (called first thing in `main`), [`wayland_probe_complains`]
//! and [`should_disable_device_select`] (the decisions, pure).

use std::ffi::OsString;

/// True when libwayland's `wl_display_connect(NULL)` would print "XDG_RUNTIME_DIR is invalid or
/// not set" in an environment read through `var`: no `WAYLAND_SOCKET`, a socket name
/// (`WAYLAND_DISPLAY`, default `wayland-0`) that is not an absolute path, and an
/// `XDG_RUNTIME_DIR` that is unset or not absolute (libwayland's own test, wayland-client.c
/// `connect_to_socket`).
pub fn wayland_probe_complains(var: impl Fn(&str) -> Option<OsString>) -> bool {
    if var("WAYLAND_SOCKET").is_some() {
        return false;
    }
    let absolute = |v: Option<OsString>| v.is_some_and(|v| v.to_string_lossy().starts_with('/'));
    !absolute(var("WAYLAND_DISPLAY")) && !absolute(var("XDG_RUNTIME_DIR"))
}

/// True when Mesa's device-select layer should be turned off for this process: its Wayland
/// probe would complain (and cannot succeed), and the user has not asked the layer for
/// anything (`MESA_VK_DEVICE_SELECT`, `DRI_PRIME`) nor set `NODEVICE_SELECT` either way.
pub fn should_disable_device_select(var: impl Fn(&str) -> Option<OsString>) -> bool {
    let asked = ["NODEVICE_SELECT", "MESA_VK_DEVICE_SELECT", "DRI_PRIME"]
        .iter()
        .any(|k| var(k).is_some());
    !asked && wayland_probe_complains(var)
}

/// Sets `NODEVICE_SELECT=1` when [`should_disable_device_select`] says so; true if it did.
/// Children started afterwards inherit it (they would decide the same).
///
/// # Safety
///
/// It writes the process environment, which is sound only while no other thread reads or
/// writes it ([`std::env::set_var`]): call it first thing in `main`, before any thread exists.
#[expect(
    unsafe_code,
    reason = "std::env::set_var is unsafe since Rust 2024; the caller guarantees one thread"
)]
pub unsafe fn quiet_vulkan_probe() -> bool {
    if !should_disable_device_select(|k| std::env::var_os(k)) {
        return false;
    }
    // SAFETY: the caller guarantees that no other thread exists yet (this function's contract).
    unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env<'a>(vars: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<OsString> + 'a {
        move |k| {
            vars.iter()
                .find(|(n, _)| *n == k)
                .map(|(_, v)| OsString::from(v))
        }
    }

    #[test]
    fn the_probe_complains_exactly_when_libwayland_would() {
        assert!(wayland_probe_complains(env(&[])));
        assert!(wayland_probe_complains(env(&[(
            "WAYLAND_DISPLAY",
            "wayland-1"
        )])));
        assert!(wayland_probe_complains(env(&[(
            "XDG_RUNTIME_DIR",
            "run/user"
        )])));
        assert!(!wayland_probe_complains(env(&[(
            "XDG_RUNTIME_DIR",
            "/run/user/1000"
        )])));
        assert!(!wayland_probe_complains(env(&[(
            "WAYLAND_DISPLAY",
            "/tmp/wl.sock"
        )])));
        assert!(!wayland_probe_complains(env(&[("WAYLAND_SOCKET", "5")])));
    }

    #[test]
    fn a_users_own_device_choice_keeps_the_layer() {
        assert!(should_disable_device_select(env(&[])));
        for k in ["NODEVICE_SELECT", "MESA_VK_DEVICE_SELECT", "DRI_PRIME"] {
            assert!(!should_disable_device_select(env(&[(k, "1")])), "{k}");
        }
        assert!(!should_disable_device_select(env(&[(
            "XDG_RUNTIME_DIR",
            "/run/user/0"
        )])));
    }
}
