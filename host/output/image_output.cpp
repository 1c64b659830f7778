#include "output/image_output.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <thread>

#include <glm/matrix.hpp>

#include <ImfChannelList.h>
#include <ImfDoubleAttribute.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfIO.h>
#include <ImfInputFile.h>
#include <ImfMatrixAttribute.h>
#include <ImfOutputFile.h>
#include <ImfStandardAttributes.h>
#include <ImfStringAttribute.h>
#include <ImfStringVectorAttribute.h>
#include <ImfThreading.h>
#include <stb_image_write.h>

#include "output/channels.h"
#include "util/atomic_file.h"
#include "util/errors.h"

namespace rayfold::core {
namespace {

struct Channel {
  const char* name;
  Imf::PixelType type;
  size_t offset;
  unsigned plane;  // rayfold::Channels
};

const Channel kChannels[] = {
    {"Z", Imf::FLOAT, offsetof(rf_pixel_hit, z), kDepth},
    {"N.X", Imf::FLOAT, offsetof(rf_pixel_hit, nx), kNormal},
    {"N.Y", Imf::FLOAT, offsetof(rf_pixel_hit, ny), kNormal},
    {"N.Z", Imf::FLOAT, offsetof(rf_pixel_hit, nz), kNormal},
    {"U", Imf::FLOAT, offsetof(rf_pixel_hit, u), kUv},
    {"V", Imf::FLOAT, offsetof(rf_pixel_hit, v), kUv},
    {"InstanceID", Imf::UINT, offsetof(rf_pixel_hit, instance), kInstanceId},
    {"PrimitiveID", Imf::UINT, offsetof(rf_pixel_hit, primitive), kPrimitiveId},
};

// Slices of the channels in `planes`; read_exr asks for all, and OpenEXR
// fills a channel the file lacks with 0.
Imf::FrameBuffer frame_buffer(const rf_pixel_hit* base, int width, unsigned planes = kAllChannels) {
  Imf::FrameBuffer fb;
  char* bytes = reinterpret_cast<char*>(const_cast<rf_pixel_hit*>(base));
  for (const Channel& c : kChannels)
    if (planes & c.plane)
      fb.insert(c.name, Imf::Slice(c.type, bytes + c.offset, sizeof(rf_pixel_hit), sizeof(rf_pixel_hit) * width));
  return fb;
}

// A column-vector transform as Imath's row-vector matrix (the transpose).
template <class M, class T>
M imath_matrix(const glm::dmat4& m) {
  M out;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) out[c][r] = static_cast<T>(m[c][r]);
  return out;
}

void add_metadata(Imf::Header& header, const ExrMetadata& meta, int width, int height) {
  if (meta.view) {
    const ExrMetadata::View& v = *meta.view;
    // RenderMan's camera space is OpenGL's with z negated.
    glm::dmat4 flip_z(1.0);
    flip_z[2][2] = -1.0;
    const glm::dmat4 camera_from_world = flip_z * glm::inverse(v.world_from_camera);
    // (x, y, z) in camera space -> pixel (fx x / z + cx, cy - fy y / z) over
    // the image size; z_ndc = 1 / z keeps the matrix invertible.
    glm::dmat4 ndc_from_camera(0.0);
    ndc_from_camera[0][0] = v.fx / width;
    ndc_from_camera[1][1] = -v.fy / height;
    if (v.orthographic) {
      // (x, y, z) -> ((fx x + cx) / W, (cy - fy y) / H, z): no divide.
      ndc_from_camera[3][0] = v.cx / width;
      ndc_from_camera[3][1] = v.cy / height;
      ndc_from_camera[2][2] = 1.0;
      ndc_from_camera[3][3] = 1.0;
    } else {
      ndc_from_camera[2][0] = v.cx / width;
      ndc_from_camera[2][1] = v.cy / height;
      ndc_from_camera[3][2] = 1.0;
      ndc_from_camera[2][3] = 1.0;
    }
    Imf::addWorldToCamera(header, imath_matrix<Imath::M44f, float>(camera_from_world));
    Imf::addWorldToNDC(header, imath_matrix<Imath::M44f, float>(ndc_from_camera * camera_from_world));
    header.insert("rayfold:cameraToWorld", Imf::M44dAttribute(imath_matrix<Imath::M44d, double>(v.world_from_camera)));
    header.insert("rayfold:fx", Imf::DoubleAttribute(v.fx));
    header.insert("rayfold:fy", Imf::DoubleAttribute(v.fy));
    header.insert("rayfold:cx", Imf::DoubleAttribute(v.cx));
    header.insert("rayfold:cy", Imf::DoubleAttribute(v.cy));
    header.insert("rayfold:projection", Imf::StringAttribute(v.orthographic ? "orthographic" : "perspective"));
  }
  if (!meta.instance_names.empty())
    header.insert("rayfold:instanceNames", Imf::StringVectorAttribute(meta.instance_names));
  if (!meta.labels.empty()) header.insert("rayfold:labels", Imf::StringVectorAttribute(meta.labels));
  for (const auto& [name, value] : meta.strings) header.insert("rayfold:" + name, Imf::StringAttribute(value));
}

// OpenEXR's output stream over a checked FILE*. OpenEXR writes the file's
// offset table from OutputFile's destructor and drops any exception there,
// so a full disk at that point would pass unseen: every failure is also kept
// here and close() reports it.
class CheckedExrStream : public Imf::OStream {
 public:
  CheckedExrStream(const std::string& temp, const std::string& path)
      : Imf::OStream(temp.c_str()), path_(path), file_(std::fopen(temp.c_str(), "wb")) {
    if (!file_) throw RuntimeFailure(path + ": cannot write the EXR file: " + std::strerror(errno));
  }
  ~CheckedExrStream() override {
    if (file_) std::fclose(file_);
  }
  void write(const char c[], int n) override {
    if (!error_ && std::fwrite(c, 1, static_cast<size_t>(n), file_) != static_cast<size_t>(n)) error_ = errno;
    if (error_) throw std::runtime_error(std::strerror(error_));
  }
  uint64_t tellp() override { return static_cast<uint64_t>(std::ftell(file_)); }
  void seekp(uint64_t pos) override {
    if (!error_ && std::fseek(file_, static_cast<long>(pos), SEEK_SET) != 0) error_ = errno;
  }
  // Flushes and closes; RuntimeFailure naming the file on any failure.
  void close() {
    const bool flushed = std::fflush(file_) == 0;
    if (!error_ && !flushed) error_ = errno;
    const bool closed = std::fclose(file_) == 0;
    file_ = nullptr;
    if (!error_ && !closed) error_ = errno;
    if (error_) throw RuntimeFailure(path_ + ": cannot write the EXR file: " + std::strerror(error_));
  }

 private:
  std::string path_;
  std::FILE* file_;
  int error_ = 0;
};

}  // namespace

ExrMetadata view_metadata(const Camera& camera, const Scene& scene, const std::string& scene_label,
                          const std::string& fold, bool planar_depth, bool exact_depth, const std::string& version) {
  ExrMetadata m;
  const Intrinsics k = intrinsics(camera);
  m.view = ExrMetadata::View{camera.world_from_camera, k.fx, k.fy, k.cx, k.cy, is_orthographic(camera)};
  for (const Instance& i : scene.instances) m.instance_names.push_back(i.name);
  m.labels = scene.labels;
  m.strings = {{"version", version},
               {"scene", scene_label},
               {"fold", fold},
               {"depthKind", planar_depth ? "planar" : "distance"},
               {"depth", std::string(planar_depth ? "Z is the depth along the camera's axis (camera-space -z, "
                                                    "--depth planar); +inf on a miss"
                                                  : "Z is the distance from the eye along the pixel's ray (not "
                                                    "camera-space z); +inf on a miss") +
                             (exact_depth ? ". Exact: from the pixel's exact ray and the hit triangle's plane in "
                                            "double-float, rounded once (--exact-depth)"
                                          : "")},
               {"miss",
                "InstanceID, PrimitiveID, MaterialID, Label and FlowVisible are 4294967295 on a miss (MaterialID "
                "4294967294 where the triangle has no material); Z is +inf, every other channel 0"}};
  return m;
}

namespace {

struct CompressionName {
  const char* name;
  rayfold::ExrCompression method;
  Imf::Compression imf;
};
constexpr CompressionName kCompressions[] = {
    {"none", rayfold::ExrCompression::none, Imf::NO_COMPRESSION},
    {"rle", rayfold::ExrCompression::rle, Imf::RLE_COMPRESSION},
    {"zips", rayfold::ExrCompression::zips, Imf::ZIPS_COMPRESSION},
    {"zip", rayfold::ExrCompression::zip, Imf::ZIP_COMPRESSION},
    {"piz", rayfold::ExrCompression::piz, Imf::PIZ_COMPRESSION},
};

}  // namespace

const char* exr_compressions() { return "none, rle, zips, zip, piz"; }

rayfold::ExrCompression parse_exr_compression(const std::string& name) {
  for (const CompressionName& c : kCompressions)
    if (name == c.name) return c.method;
  for (const char* lossy : {"pxr24", "b44", "b44a", "dwaa", "dwab"})
    if (name == lossy)
      throw InputError("", "EXR compression '" + name + "' is lossy: a G-buffer's floats and ids must read back bit "
                               "for bit (lossless: " + exr_compressions() + ")");
  throw InputError("", "unknown EXR compression '" + name + "' (" + exr_compressions() + ")");
}

namespace {

// One EXR channel in memory: pixel (x, y) at base + y * ystride + x * xstride.
struct ExrSlice {
  const char* name;
  Imf::PixelType type;
  const char* base;
  size_t xstride, ystride;
};

void write_slices(const std::string& path, int width, int height, const std::vector<ExrSlice>& slices,
                  const ExrMetadata* metadata, rayfold::ExrCompression compression) {
  // ZIP compression of a 1280x720 G-buffer takes ten times the trace on one
  // thread; OpenEXR compresses blocks in parallel on its global pool
  // (352 -> 190 ms on 2 cores, same bytes).
  static const bool pool = [] {
    Imf::setGlobalThreadCount(static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));
    return true;
  }();
  (void)pool;
  AtomicFile file(path);
  CheckedExrStream stream(file.temp_path(), path);
  try {
    Imf::Header header(width, height);
    header.compression() = Imf::ZIP_COMPRESSION;
    for (const CompressionName& c : kCompressions)
      if (c.method == compression) header.compression() = c.imf;
    Imf::FrameBuffer fb;
    for (const ExrSlice& c : slices) {
      header.channels().insert(c.name, Imf::Channel(c.type));
      fb.insert(c.name, Imf::Slice(c.type, const_cast<char*>(c.base), c.xstride, c.ystride));
    }
    if (metadata) add_metadata(header, *metadata, width, height);
    Imf::OutputFile out(stream, header, Imf::globalThreadCount());
    out.setFrameBuffer(fb);
    out.writePixels(height);
  } catch (const std::exception& e) {
    throw RuntimeFailure(path + ": cannot write the EXR file: " + e.what());
  }
  stream.close();
  file.commit();
}

}  // namespace

void write_exr(const std::string& path, ConstSpan<rf_pixel_hit> hits, int width, int height,
               const ExrMetadata* metadata, unsigned channels, rayfold::ExrCompression compression) {
  RF_CHECK_EQ(hits.size(), static_cast<size_t>(width) * height, "hit buffer does not match the image size");
  std::vector<ExrSlice> slices;
  const char* bytes = reinterpret_cast<const char*>(hits.data());
  for (const Channel& c : kChannels)
    if (channels & c.plane)
      slices.push_back({c.name, c.type, bytes + c.offset, sizeof(rf_pixel_hit), sizeof(rf_pixel_hit) * width});
  write_slices(path, width, height, slices, metadata, compression);
}

void write_exr(const std::string& path, const GBuffer& g, unsigned channels, const ExrMetadata* metadata,
               rayfold::ExrCompression compression) {
  std::vector<ExrSlice> slices;
  const size_t w = static_cast<size_t>(g.width);
  for (const PlaneSpec& p : plane_specs()) {
    if (!(channels & p.bit)) continue;
    const char* base = p.floats ? reinterpret_cast<const char*>((g.*p.floats).data())
                                : reinterpret_cast<const char*>((g.*p.ids).data());
    RF_CHECK_EQ(p.floats ? (g.*p.floats).size() : (g.*p.ids).size(), p.components * w * g.height,
                "a plane of another size than its G-buffer");
    const size_t x = p.components * sizeof(uint32_t);
    for (int k = 0; k < p.components; ++k)
      slices.push_back({p.exr[k], p.floats ? Imf::FLOAT : Imf::UINT, base + k * sizeof(uint32_t), x, x * w});
  }
  write_slices(path, g.width, g.height, slices, metadata, compression);
}

ExrMetadata read_exr_metadata(const std::string& path, int* width, int* height) {
  try {
    Imf::InputFile in(path.c_str());
    const Imf::Header& h = in.header();
    const Imath::Box2i dw = h.dataWindow();
    *width = dw.max.x - dw.min.x + 1;
    *height = dw.max.y - dw.min.y + 1;
    ExrMetadata m;
    const auto* pose = h.findTypedAttribute<Imf::M44dAttribute>("rayfold:cameraToWorld");
    if (pose) {
      ExrMetadata::View v;
      for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) v.world_from_camera[c][r] = pose->value()[c][r];
      auto number = [&](const char* name) {
        const auto* a = h.findTypedAttribute<Imf::DoubleAttribute>(name);
        if (!a) throw InputError(path, std::string("has rayfold:cameraToWorld but no ") + name);
        return a->value();
      };
      v.fx = number("rayfold:fx");
      v.fy = number("rayfold:fy");
      v.cx = number("rayfold:cx");
      v.cy = number("rayfold:cy");
      const auto* projection = h.findTypedAttribute<Imf::StringAttribute>("rayfold:projection");
      v.orthographic = projection && projection->value() == "orthographic";
      m.view = v;
    }
    if (const auto* a = h.findTypedAttribute<Imf::StringVectorAttribute>("rayfold:instanceNames"))
      m.instance_names = a->value();
    if (const auto* a = h.findTypedAttribute<Imf::StringVectorAttribute>("rayfold:labels")) m.labels = a->value();
    for (auto it = h.begin(); it != h.end(); ++it) {
      const std::string name = it.name();
      const auto* text = dynamic_cast<const Imf::StringAttribute*>(&it.attribute());
      if (text && name.rfind("rayfold:", 0) == 0 && name != "rayfold:projection")
        m.strings.emplace_back(name.substr(8), text->value());
    }
    return m;
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    throw InputError(path, std::string("cannot read the EXR file: ") + e.what());
  }
}

GBuffer read_exr_planes(const std::string& path) {
  try {
    Imf::InputFile in(path.c_str());
    const Imath::Box2i dw = in.header().dataWindow();
    GBuffer g;
    g.width = dw.max.x - dw.min.x + 1;
    g.height = dw.max.y - dw.min.y + 1;
    g.channels = 0;
    const size_t w = static_cast<size_t>(g.width), n = w * g.height;
    Imf::FrameBuffer fb;
    for (const PlaneSpec& p : plane_specs()) {
      bool whole = true;
      for (int k = 0; k < p.components; ++k) whole = whole && in.header().channels().findChannel(p.exr[k]);
      if (!whole) continue;
      g.channels |= p.bit;
      char* base;
      if (p.floats) {
        (g.*p.floats).assign(p.components * n, 0.0f);
        base = reinterpret_cast<char*>((g.*p.floats).data());
      } else {
        (g.*p.ids).assign(p.components * n, 0u);
        base = reinterpret_cast<char*>((g.*p.ids).data());
      }
      const size_t x = p.components * sizeof(uint32_t);
      // The data window's origin at the planes' first pixel.
      base -= static_cast<ptrdiff_t>(dw.min.x) * x + static_cast<ptrdiff_t>(dw.min.y) * x * w;
      for (int k = 0; k < p.components; ++k)
        fb.insert(p.exr[k], Imf::Slice(p.floats ? Imf::FLOAT : Imf::UINT, base + k * sizeof(uint32_t), x, x * w));
    }
    in.setFrameBuffer(fb);
    in.readPixels(dw.min.y, dw.max.y);
    return g;
  } catch (const std::exception& e) {
    throw InputError(path, std::string("cannot read the EXR file: ") + e.what());
  }
}

std::vector<rf_pixel_hit> read_exr(const std::string& path, int* width, int* height, unsigned* channels) {
  try {
    Imf::InputFile in(path.c_str());
    if (channels) {
      *channels = kAllChannels;
      for (const Channel& c : kChannels)
        if (!in.header().channels().findChannel(c.name)) *channels &= ~c.plane;
    }
    const Imath::Box2i dw = in.header().dataWindow();
    *width = dw.max.x - dw.min.x + 1;
    *height = dw.max.y - dw.min.y + 1;
    std::vector<rf_pixel_hit> hits(static_cast<size_t>(*width) * *height);
    const rf_pixel_hit* origin = hits.data() - dw.min.x - static_cast<ptrdiff_t>(dw.min.y) * *width;
    in.setFrameBuffer(frame_buffer(origin, *width));
    in.readPixels(dw.min.y, dw.max.y);
    return hits;
  } catch (const std::exception& e) {
    throw InputError(path, std::string("cannot read the EXR file: ") + e.what());
  }
}

void write_png(const std::string& path, ConstSpan<rf_pixel_hit> hits, int width, int height) {
  RF_CHECK_EQ(hits.size(), static_cast<size_t>(width) * height, "hit buffer does not match the image size");
  std::vector<uint8_t> rgb(hits.size() * 3, 0);
  auto to_byte = [](float n) {
    const float c = std::round((n * 0.5f + 0.5f) * 255.0f);
    return static_cast<uint8_t>(c < 0.0f ? 0.0f : (c > 255.0f ? 255.0f : c));
  };
  for (size_t i = 0; i < hits.size(); ++i) {
    if (hits[i].instance == RF_INVALID) continue;
    rgb[3 * i + 0] = to_byte(hits[i].nx);
    rgb[3 * i + 1] = to_byte(hits[i].ny);
    rgb[3 * i + 2] = to_byte(hits[i].nz);
  }
  // Encoded in memory and written by write_temp_bytes: stb's own file
  // writer does not check its writes, and reported success on a full disk.
  std::vector<uint8_t> png;
  auto append = [](void* context, void* data, int size) {
    auto* out = static_cast<std::vector<uint8_t>*>(context);
    out->insert(out->end(), static_cast<uint8_t*>(data), static_cast<uint8_t*>(data) + size);
  };
  if (!stbi_write_png_to_func(append, &png, width, height, 3, rgb.data(), width * 3))
    throw RuntimeFailure(path + ": cannot encode the PNG file");
  AtomicFile file(path);
  write_temp_bytes(file, png.data(), png.size());
  file.commit();
}

}  // namespace rayfold::core
