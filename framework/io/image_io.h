// Reading and writing images and volumes, keeping spacing and origin:
//  - 2D: PNG, TIFF, JPEG, BMP through OpenCV (grey levels; colour is converted to grey);
//    MetaImage, NIfTI, NRRD and INRIMAGE with two dimensions (or a third of size 1) also read as 2D.
//  - 3D: MetaImage .mha/.mhd (raw or zlib-compressed, separate .raw/.zraw data file or LOCAL),
//    NIfTI .nii/.nii.gz (NIfTI-1 and NIfTI-2 read; NIfTI-1 written, NIfTI-2 for more than 32767
//    voxels along an axis) and .hdr/.img pairs (read only; either file names the pair, each may
//    be gzipped; an ANALYZE 7.5 .hdr, which has no orientation, is refused), NRRD .nrrd/.nhdr
//    (raw or gzip, attached or detached data, LPS/RAS space directions; framework/io/nrrd.cpp)
//    and INRIMAGE-4 .inr/.inr.gz (framework/io/inr.cpp).
//    Voxel types: 8- to 64-bit integers, float and double, read as float (rounded once).
//    World coordinates are LPS; a format storing RAS is converted on reading and writing.
//    Orientation: an image stored with flipped or permuted axes is reordered on reading so that
//    its grid is axis-aligned (every voxel keeps its world position); an oblique one keeps its
//    rotation as Grid::direction (a reflection is made a rotation by reversing the last axis);
//    direction cosines that are not orthonormal to 1e-3 (a sheared grid) are refused. Writers
//    store the direction (MetaImage TransformMatrix, NIfTI qform + sform, NRRD space directions;
//    INRIMAGE has none and refuses a rotated image).
//    NIfTI orientation as nibabel reads it (its `affine`, Nifti1Header.get_best_affine): the
//    sform when sform_code > 0, else the qform when qform_code > 0, else the pixdim grid at the
//    origin (the header's "method 1"); ImageReadOptions::nifti_transform picks one instead.
//  - DICOM, read only, through GDCM (framework/io/dicom.cpp; any transfer syntax GDCM decodes:
//    uncompressed, deflated, RLE, JPEG, JPEG-LS, JPEG 2000), values after RescaleSlope/Intercept:
//    a .dcm/.dicom file or any file with "DICM" at byte 128 (one slice: 2D in its own plane, x
//    along the rows, origin = ImagePositionPatient projected on the row and column directions;
//    multi-frame: 3D with GDCM's geometry; a cine's frames (FrameTime) 1 apart, with a warning),
//    or a folder holding one series (3D: slices sorted along row x column, the slice spacing
//    from their positions, origin = the first slice's ImagePositionPatient, LPS). Files in the folder count when named .dcm/.dicom or carrying
//    the magic; others are ignored. A folder with several SeriesInstanceUIDs is refused with a
//    line listing them; "folder#UID" reads one. Slices of different size, orientation or pixel
//    spacing, two at one position or a missing one (a slice off its evenly spaced place by more
//    than 10 % of the spacing) are refused naming the file; colour DICOM is not supported.
// Bad files (missing, truncated, wrong dimension, NaN voxels, unsupported type) throw an
// InputError naming the file and the header key or voxel at fault. Writers write to a
// temporary file and rename it, so a failed write leaves nothing behind.
#pragma once

#include "framework/core/image.h"
#include "framework/core/options.h"

#include <array>
#include <cstdint>
#include <string>

namespace dsnake {

// True if `path` names DICOM: a folder (a series), "folder#SeriesInstanceUID", a .dcm or .dicom
// file, or a file with the "DICM" magic at byte 128.
bool is_dicom_input(const std::string& path);

// Number of dimensions of the image in `path` (2 or 3), from its header or extension.
int image_file_dimension(const std::string& path);

// Which of a NIfTI header's transforms places the voxels. kAuto: nibabel's rule (the sform
// when sform_code > 0, else the qform when qform_code > 0, else pixdim at the origin), with one
// warning line on stderr when both codes are set and the two disagree by more than a voxel or a
// degree. kSform / kQform: that transform; when its code is 0 (the file has none), one warning
// line says so and the auto rule applies to what the file has. With the sform, the spacing is
// its column norms (so every voxel lands where nibabel's affine puts it; pixdim, which ITK
// takes for the spacing, is ignored where a column is not zero).
enum class NiftiTransform { kAuto, kSform, kQform };
template <>
struct EnumNames<NiftiTransform> {
  static constexpr std::array<std::pair<NiftiTransform, const char*>, 3> table{
      {{NiftiTransform::kAuto, "auto"}, {NiftiTransform::kSform, "sform"}, {NiftiTransform::kQform, "qform"}}};
};

// Options for read_image; the one-argument form uses the defaults. The experiment file's
// `image` object holds them (they apply to every image file an experiment reads).
struct ImageReadOptions {
  NiftiTransform nifti_transform = NiftiTransform::kAuto;

  template <class V>
  void visit(V& v) {
    v(nifti_transform, Key{"nifti_transform", "",
                           "which NIfTI transform places the voxels of every NIfTI the experiment reads (image, "
                           "ground_truth.mask, template.reference_image, template.init.mask): auto (nibabel's rule: "
                           "the sform when sform_code > 0, else the qform, else pixdim; a warning when both are set "
                           "and disagree by more than a voxel or a degree), sform or qform (a transform the file "
                           "lacks falls back to auto, with a warning)"});
  }
};

// How a file stores its voxels and how read_image reordered them so that its grid is
// axis-aligned (or, oblique, a rotation): what write_image_on_source_grid needs to write an
// image on the read grid back on the file's own grid. A few hundred bytes; no voxels.
struct ImageLayout {
  std::string path;                          // the file read
  int ndims = 3;                             // spatial dimensions as stored
  std::array<int64_t, 3> size{1, 1, 1};      // stored voxels per axis
  std::array<double, 3> spacing{1, 1, 1};    // as stored (mm)
  std::array<double, 3> origin{0, 0, 0};     // world (LPS mm) position of the first stored voxel
  std::array<std::array<double, 3>, 3> axes{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};  // stored axis directions (LPS)
  // Stored index axis a became read axis to[a], reversed when sign[a] < 0: stored index i is read
  // index j with j[to[a]] = sign[a] > 0 ? i[a] : size[a] - 1 - i[a].
  std::array<int, 3> to{0, 1, 2}, sign{1, 1, 1};
  std::string nifti_header;  // a NIfTI input's own header as stored (348 bytes, NIfTI-2 540); "" for other formats
};

template <int D>
Image<D> read_image(const std::string& path);
template <int D>
Image<D> read_image(const std::string& path, const ImageReadOptions& options);
// The same, filling `layout` (when not null) with how the file stores its voxels.
template <int D>
Image<D> read_image(const std::string& path, const ImageReadOptions& options, ImageLayout* layout);

// Formats by extension: .mha .mhd .nii .nii.gz .nrrd .nhdr .inr .inr.gz (float32 voxels), and for D = 2 also .png .tif
// .tiff (8-bit after clamping to [0, 255]; spacing is lost in PNG/TIFF, so prefer .mha).
template <int D>
void write_image(const Image<D>& image, const std::string& path);

// Options for write_image; the two-argument form uses the defaults.
struct ImageWriteOptions {
  bool compress = false;  // MetaImage: zlib-compressed data (CompressedData = True); NRRD: gzip encoding;
                          // NIfTI, INRIMAGE: use .nii.gz, .inr.gz
  bool label = false;     // a label map: stored as uint8 (values rounded and clamped to [0, 255]; MetaImage, NIfTI, NRRD)
};
template <int D>
void write_image(const Image<D>& image, const std::string& path, const ImageWriteOptions& options);

// Writes `image` (on the grid read_image made of `layout`'s file) as a NIfTI `path` (.nii or
// .nii.gz) on that file's own grid: the same dimensions, voxel order and world positions. For a
// NIfTI input, its own header (qform, sform, their codes, pixdim, xyzt_units, description; a
// NIfTI-2's or a pair's as a single-file NIfTI-1's) with the datatype, data offset and scaling of
// what is stored; for any other format, the NIfTI that nibabel maps to the same world positions
// (qform and sform, codes 1). A grid of more than 32767 voxels along an axis, which NIfTI-1
// cannot hold, is written as NIfTI-2 (a NIfTI-2 input's own header). Holds one buffer of the
// stored values (a byte a voxel for a label map) besides the image; written atomically.
template <int D>
void write_image_on_source_grid(const Image<D>& image, const ImageLayout& layout, const std::string& path,
                                const ImageWriteOptions& options);

// Vector fields as multi-component MetaImage (.mha, ElementNumberOfChannels = D), NIfTI
// (intent vector, 5th dimension = D), NRRD (a leading axis of kind vector) or INRIMAGE (VDIM = D).
template <int D>
void write_vector_field(const VectorField<D>& field, const std::string& path);
// The same for a field on the grid read_image made of `layout`'s file: MetaImage, NIfTI and NRRD
// get that file's voxel order and axes (the vectors stay world components).
template <int D>
void write_vector_field(const VectorField<D>& field, const std::string& path, const ImageLayout& layout);
template <int D>
VectorField<D> read_vector_field(const std::string& path);

// Copies an image, volume or vector field from `in` to `out` (formats by extension) keeping
// spacing, origin and direction; the voxels go through as float32 (8-bit for .png/.tif/...).
// MetaImage, NIfTI and NRRD outputs keep the input's voxel order and axes; INRIMAGE and the
// raster formats, which store no direction, get the axis-aligned grid read_image makes.
// Bad input throws InputError as read_image does; nothing is written then.
void convert_image_file(const std::string& in, const std::string& out, const ImageWriteOptions& options = {},
                        const ImageReadOptions& read_options = {});

}  // namespace dsnake
