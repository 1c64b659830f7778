// The compact traversal layout (kernels/rf_types.h) as the host sees it.
#pragma once

#include "rf_common.h"
#include "rf_types.h"

static_assert(sizeof(rf_node) == 32, "rf_node is 32 bytes on host and device");
static_assert(sizeof(rf_wide_node) == 128, "rf_wide_node is 128 bytes on host and device");
static_assert(sizeof(rf_wide8_node) == 256, "rf_wide8_node is 256 bytes on host and device");
static_assert(sizeof(rf_tri) == 56, "rf_tri is 56 bytes on host and device");
static_assert(sizeof(rf_instance) == 64, "rf_instance is 64 bytes on host and device");
static_assert(sizeof(rf_alpha_tri) == 48, "rf_alpha_tri is 48 bytes on host and device");
static_assert(sizeof(rf_alpha_image) == 16, "rf_alpha_image is 16 bytes on host and device");
static_assert(sizeof(rf_normal_xform) == 36, "rf_normal_xform is 36 bytes on host and device");
static_assert(sizeof(rf_depth_xform) == 96, "rf_depth_xform is 96 bytes on host and device");
static_assert(sizeof(rf_pixel_hit) == 32, "rf_pixel_hit is 32 bytes on host and device");
static_assert(sizeof(rf_query_ray) == 32, "rf_query_ray is 32 bytes on host and device");
