// Images on the grid of the file they were read from (image_io.h, ImageLayout): the reader's
// reordering (image_io.cpp, align_axes) undone for writing, in one buffer of the stored values.
#include "framework/io/image_io.h"

#include "framework/core/errors.h"
#include "framework/io/image_io_detail.h"

#include <algorithm>
#include <array>
#include <cstring>
#include <string>
#include <vector>

namespace dsnake {

namespace detail {

namespace {

// Calls f(l, m) for each voxel of `layout`'s file in its stored order l, m being that voxel's
// index on the grid read_image made of it (ImageLayout::to).
template <class F>
void for_stored_voxels(const ImageLayout& layout, F&& f) {
  std::array<int64_t, 3> read_size{1, 1, 1};
  for (int a = 0; a < 3; ++a) read_size[layout.to[a]] = layout.size[a];
  const std::array<int64_t, 3> read_stride{1, read_size[0], read_size[0] * read_size[1]};
  const int64_t n = layout.size[0] * layout.size[1] * layout.size[2];
  for (int64_t l = 0; l < n; ++l) {
    const int64_t idx[3] = {l % layout.size[0], (l / layout.size[0]) % layout.size[1],
                            l / (layout.size[0] * layout.size[1])};
    int64_t m = 0;
    for (int a = 0; a < 3; ++a)
      m += (layout.sign[a] > 0 ? idx[a] : layout.size[a] - 1 - idx[a]) * read_stride[layout.to[a]];
    f(l, m);
  }
}

}  // namespace

void restore_stored_order(RawVolume& v, const ImageLayout& layout) {
  DSNAKE_ASSERT(v.num_voxels() == layout.size[0] * layout.size[1] * layout.size[2],
                "the volume is on the grid read from the layout's file");
  const bool reordered = layout.to != std::array<int, 3>{0, 1, 2} || layout.sign != std::array<int, 3>{1, 1, 1};
  if (!reordered) return copy_geometry(v, layout);
  const int c = v.channels;
  const std::vector<float>& read = v.data();
  std::vector<float> stored(read.size());
  for_stored_voxels(layout, [&](int64_t l, int64_t m) {
    for (int k = 0; k < c; ++k) stored[size_t(l * c + k)] = read[size_t(m * c + k)];
  });
  v.values = std::move(stored);
  v.borrowed = nullptr;
  copy_geometry(v, layout);
}

bool stores_direction(const std::string& ext) {
  return ext == ".mha" || ext == ".mhd" || ext == ".nii" || ext == ".nii.gz" || ext == ".nrrd" || ext == ".nhdr";
}

namespace {

// The values of `image` in the stored order of `layout`'s file, as uint8 (label) or float32
// bytes (byte-swapped when `swap`), into one buffer.
template <int D>
std::string values_in_stored_order(const Image<D>& image, const ImageLayout& layout, bool label, bool swap) {
  const Grid<D>& g = image.grid();
  for (int a = 0; a < 3; ++a) {
    const int64_t read_size = layout.to[a] < D ? g.size[layout.to[a]] : 1;
    DSNAKE_ASSERT(read_size == layout.size[a], "the image is on the grid read from the layout's file");
  }
  std::string out(size_t(g.num_voxels()) * (label ? 1 : sizeof(float)), '\0');
  for_stored_voxels(layout, [&](int64_t l, int64_t m) {
    const float value = image[m];
    if (label) {
      out[size_t(l)] = char(label_byte(value));
    } else {
      char* p = out.data() + size_t(l) * sizeof(float);
      std::memcpy(p, &value, sizeof(float));
      if (swap) std::reverse(p, p + sizeof(float));
    }
  });
  return out;
}

}  // namespace

}  // namespace detail

using namespace detail;

template <int D>
void write_image_on_source_grid(const Image<D>& image, const ImageLayout& layout, const std::string& path,
                                const ImageWriteOptions& options) {
  const std::string ext = extension_of(path);
  DSNAKE_ASSERT(ext == ".nii" || ext == ".nii.gz", "write_image_on_source_grid writes NIfTI");
  bool swap = false;
  std::string header;
  if (!layout.nifti_header.empty()) {
    header = nifti_header_for_values(layout.nifti_header, options.label, swap);
  } else {
    RawVolume v;
    copy_geometry(v, layout);
    v.label = options.label;
    header = nifti_header_of(v);
  }
  const std::string values = values_in_stored_order(image, layout, options.label, swap);
  write_nifti_parts({header, values}, path);
}

template void write_image_on_source_grid<2>(const Image<2>&, const ImageLayout&, const std::string&, const ImageWriteOptions&);
template void write_image_on_source_grid<3>(const Image<3>&, const ImageLayout&, const std::string&, const ImageWriteOptions&);

}  // namespace dsnake
