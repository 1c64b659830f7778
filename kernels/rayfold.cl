/* rayfold.cl - device entry points. The host prepends rf_common.h,
 * rf_types.h, rf_geometry.h and rf_trace.h (host/kernel_sources.cpp), so this
 * file holds only what is device-specific: one work-item per ray-list entry. */

__kernel void rf_trace_primary(__global const rf_node* nodes, __global const rf_tri* tris,
                               __global const rf_instance* instances, __global const rf_normal_xform* normal_xforms,
                               uint tlas_root, __global const uint* rays, uint ray_count, float scale_x,
                               float scale_y, int kx0, int ky0, int width, int height, int xpair, int ypair,
                               __global rf_pixel_hit* out) {
  const uint i = get_global_id(0);
  if (i >= ray_count) return;
  rf_camera cam;
  cam.scale_x = scale_x;
  cam.scale_y = scale_y;
  cam.kx0 = kx0;
  cam.ky0 = ky0;
  cam.width = width;
  cam.height = height;
  cam.xpair = xpair;
  cam.ypair = ypair;
  rf_trace_entry(rays[i], &cam, nodes, tris, instances, normal_xforms, tlas_root, out);
}
