//! `export_scene!` and the entry point both export macros share.

/// Export a scene plugin: defines `hapticd_plugin_entry` and the scene vtable around a
/// [`SceneFactory`].
#[macro_export]
macro_rules! export_scene {
    (name: $name:literal, description: $description:literal, create: $create:path $(,)?) => {
        $crate::export_scene!(@vtable $name, $description, $create, None);
    };
    (
        name: $name:literal,
        description: $description:literal,
        create: $create:path,
        engines: [$($engine:literal),+ $(,)?],
        check: $check:path $(,)?
    ) => {
        const _: () = {
            use $crate::abi::*;

            unsafe extern "C" fn __hapticd_engine(index: u32) -> *const ::core::ffi::c_char {
                const ENGINES: &[&::core::ffi::CStr] = &[$(
                    match ::core::ffi::CStr::from_bytes_with_nul(concat!($engine, "\0").as_bytes()) {
                        Ok(name) => name,
                        Err(_) => panic!("an engine name holds no NUL"),
                    }
                ),+];
                $crate::export::scene_engine(ENGINES, index)
            }
            // SAFETY: the host keeps the extension's contract on every pointer.
            unsafe extern "C" fn __hapticd_check(
                path: *const ::core::ffi::c_char,
                pointer_count: u32,
                message: *mut ::core::ffi::c_char,
                capacity: usize,
            ) -> i32 {
                unsafe {
                    $crate::export::scene_check($check, path, pointer_count, message, capacity)
                }
            }
            static FILES: $crate::export::StaticSceneFiles =
                $crate::export::StaticSceneFiles(HapticdSceneFiles {
                    struct_size: ::core::mem::size_of::<HapticdSceneFiles>() as u32,
                    engine: Some(__hapticd_engine),
                    check: Some(__hapticd_check),
                });
            $crate::export_scene!(@vtable $name, $description, $create, Some(&FILES));
        };
    };
    (@vtable $name:literal, $description:literal, $create:path, $files:expr) => {
        const _: () = {
            use $crate::abi::*;
            use $crate::export::StaticSceneVtable;

            // SAFETY (all seven): the host keeps the ABI's contracts on every pointer.
            unsafe extern "C" fn __hapticd_create(
                path: *const ::core::ffi::c_char,
                pointer_count: u32,
                instance: *mut *mut ::core::ffi::c_void,
                info: *mut HapticdSceneInfo,
            ) -> i32 {
                unsafe {
                    $crate::export::scene_create($create, path, pointer_count, instance, info)
                }
            }
            unsafe extern "C" fn __hapticd_destroy(instance: *mut ::core::ffi::c_void) {
                unsafe { $crate::export::scene_destroy(instance) }
            }
            unsafe extern "C" fn __hapticd_step_direct(
                instance: *mut ::core::ffi::c_void,
                dt: f64,
                pointers: *const HapticdPointer,
                count: u32,
                wrenches: *mut HapticdWrench,
            ) -> i32 {
                unsafe {
                    $crate::export::scene_step_direct(instance, dt, pointers, count, wrenches)
                }
            }
            unsafe extern "C" fn __hapticd_step_physics(
                instance: *mut ::core::ffi::c_void,
                dt: f64,
                pointers: *const HapticdPointer,
                count: u32,
                impulses: *const HapticdImpulse,
                impulse_count: u32,
                planes: *mut HapticdPlanes,
            ) -> i32 {
                unsafe {
                    $crate::export::scene_step_physics(
                        instance,
                        dt,
                        pointers,
                        count,
                        impulses,
                        impulse_count,
                        planes,
                    )
                }
            }

            unsafe extern "C" fn __hapticd_poses(
                instance: *mut ::core::ffi::c_void,
                poses: *mut HapticdBodyPose,
                capacity: u32,
            ) -> u32 {
                unsafe { $crate::export::scene_poses(instance, poses, capacity) }
            }

            unsafe extern "C" fn __hapticd_step_world(
                instance: *mut ::core::ffi::c_void,
                input: *const HapticdPhysicsInput,
                output: *mut HapticdPhysicsOutput,
            ) -> i32 {
                unsafe { $crate::export::scene_step_world(instance, input, output) }
            }

            unsafe extern "C" fn __hapticd_get_extension(
                id: *const ::core::ffi::c_char,
            ) -> *const ::core::ffi::c_void {
                unsafe { $crate::export::scene_extension(id, $files) }
            }

            static VTABLE: StaticSceneVtable = StaticSceneVtable(HapticdSceneVtable {
                struct_size: ::core::mem::size_of::<HapticdSceneVtable>() as u32,
                create: Some(__hapticd_create),
                destroy: Some(__hapticd_destroy),
                step_direct: Some(__hapticd_step_direct),
                step_physics: Some(__hapticd_step_physics),
                poses: Some(__hapticd_poses),
                step_world: Some(__hapticd_step_world),
                get_extension: Some(__hapticd_get_extension),
            });

            $crate::__hapticd_plugin_entry!(
                HAPTICD_KIND_SCENE,
                $name,
                $description,
                ::core::ptr::null(),
                &VTABLE.0
            );
        };
    };
}

/// Defines the descriptor of a plugin of `$kind` and the `hapticd_plugin_entry` that hands
/// it out.
#[doc(hidden)]
#[macro_export]
macro_rules! __hapticd_plugin_entry {
    ($kind:expr, $name:literal, $description:literal, $mechanism:expr, $scene:expr) => {
        static DESCRIPTOR: $crate::export::StaticDescriptor =
            $crate::export::StaticDescriptor($crate::abi::HapticdPluginDescriptor {
                abi_major: $crate::abi::HAPTICD_ABI_MAJOR,
                abi_minor: $crate::abi::HAPTICD_ABI_MINOR,
                kind: $kind,
                name: concat!($name, "\0").as_ptr().cast(),
                version: concat!(env!("CARGO_PKG_VERSION"), "\0").as_ptr().cast(),
                description: concat!($description, "\0").as_ptr().cast(),
                mechanism: $mechanism,
                scene: $scene,
            });

        /// [main] The plugin's entry point.
        #[unsafe(no_mangle)]
        pub unsafe extern "C" fn hapticd_plugin_entry(
            host: *const $crate::abi::HapticdHost,
        ) -> *const $crate::abi::HapticdPluginDescriptor {
            // SAFETY: the host keeps `host` valid for the life of the process (ABI v1).
            unsafe { $crate::export::entry(host, &DESCRIPTOR) }
        }
    };
}
