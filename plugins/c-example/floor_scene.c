/*
 * floor: a scene plugin written in C, the smallest complete example of the scene ABI.
 * A direct scene: inside every haptic tick it pushes each pointer out of a floor at
 * y = -0.03 m with a spring and a damper (penalty rendering), and touches nothing else.
 *
 * Build against an installed hapticd:
 *   cc -shared -fPIC -O2 $(pkg-config --cflags hapticd-plugin) floor_scene.c -o libfloor_scene.so
 * Run: hapticd --scene ./libfloor_scene.so (the plugin file must be owned by root or by
 * hapticd's user and not writable by others).
 */
#include <stdlib.h>
#include <string.h>

#include "hapticd_plugin.h"

#define FLOOR_Y -0.03    /* metres */
#define STIFFNESS 1000.0 /* N/m */
#define DAMPING 2.0      /* N·s/m, only while pressing in */

struct floor {
    uint32_t pointer_count;
};

/* [main] The scene file is ignored: this floor has no settings. */
static int32_t create(const char *path, uint32_t pointer_count, void **instance,
                      HapticdSceneInfo *info) {
    (void)path;
    if (!instance || !info) {
        return HAPTICD_ERROR_ARGUMENT;
    }
    /* Allocation is fine here, on the main thread; never in step_direct. */
    struct floor *f = malloc(sizeof *f);
    if (!f) {
        return HAPTICD_ERROR_FAILED;
    }
    f->pointer_count = pointer_count;
    *instance = f;
    info->style = HAPTICD_SCENE_DIRECT;
    info->physics_rate = 0.0;
    return HAPTICD_OK;
}

/* [main] */
static void destroy(void *instance) { free(instance); }

/* [rt] No allocation, lock, log or blocking call: this runs inside the haptic tick. */
static int32_t step_direct(void *instance, double dt, const HapticdPointer *pointers,
                           uint32_t pointer_count, HapticdWrench *wrenches) {
    const struct floor *f = instance;
    (void)dt;
    if (!f || !pointers || !wrenches || pointer_count != f->pointer_count) {
        return HAPTICD_ERROR_ARGUMENT;
    }
    for (uint32_t i = 0; i < pointer_count; i++) {
        memset(&wrenches[i], 0, sizeof wrenches[i]);
        double depth = FLOOR_Y - pointers[i].position[1];
        if (depth > 0.0) {
            double push = STIFFNESS * depth;
            double vy = pointers[i].velocity[1];
            if (vy < 0.0) {
                push -= DAMPING * vy;
            }
            wrenches[i].force[1] = push;
        }
    }
    return HAPTICD_OK;
}

static const HapticdSceneVtable vtable = {
    .struct_size = sizeof(HapticdSceneVtable),
    .create = create,
    .destroy = destroy,
    .step_direct = step_direct,
    .step_physics = NULL,
};

static const HapticdPluginDescriptor descriptor = {
    .abi_major = HAPTICD_ABI_MAJOR,
    .abi_minor = HAPTICD_ABI_MINOR,
    .kind = HAPTICD_KIND_SCENE,
    .name = "floor",
    .version = "1.0.0",
    .description = "A spring floor at y = -0.03 m, in C",
    .mechanism = NULL,
    .scene = &vtable,
};

/* [main] */
const HapticdPluginDescriptor *hapticd_plugin_entry(const HapticdHost *h) {
    if (h && h->abi_major != HAPTICD_ABI_MAJOR) {
        return NULL;
    }
    return &descriptor;
}
