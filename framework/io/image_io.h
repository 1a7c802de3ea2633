// Reading and writing images and volumes, keeping spacing and origin:
//  - 2D: PNG, TIFF, JPEG, BMP through OpenCV (grey levels; colour is converted to grey);
//    MetaImage, NIfTI, NRRD and INRIMAGE with two dimensions (or a third of size 1) also read as 2D.
//  - 3D: MetaImage .mha/.mhd (raw or zlib-compressed, separate .raw/.zraw data file or LOCAL),
//    NIfTI-1 .nii/.nii.gz, NRRD .nrrd/.nhdr (raw or gzip, attached or detached data, LPS/RAS
//    space directions; framework/io/nrrd.cpp) and INRIMAGE-4 .inr/.inr.gz (framework/io/inr.cpp).
//    World coordinates are LPS; a format storing RAS is converted on reading and writing.
//    Orientation: an image stored with flipped or permuted axes is reordered on reading so that
//    its grid is axis-aligned (every voxel keeps its world position); an oblique one keeps its
//    rotation as Grid::direction (a reflection is made a rotation by reversing the last axis);
//    direction cosines that are not orthonormal to 1e-3 (a sheared grid) are refused. Writers
//    store the direction (MetaImage TransformMatrix, NIfTI qform + sform, NRRD space directions;
//    INRIMAGE has none and refuses a rotated image).
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

#include <string>

namespace dsnake {

// True if `path` names DICOM: a folder (a series), "folder#SeriesInstanceUID", a .dcm or .dicom
// file, or a file with the "DICM" magic at byte 128.
bool is_dicom_input(const std::string& path);

// Number of dimensions of the image in `path` (2 or 3), from its header or extension.
int image_file_dimension(const std::string& path);

template <int D>
Image<D> read_image(const std::string& path);

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

// Vector fields as multi-component MetaImage (.mha, ElementNumberOfChannels = D), NIfTI
// (intent vector, 5th dimension = D), NRRD (a leading axis of kind vector) or INRIMAGE (VDIM = D).
template <int D>
void write_vector_field(const VectorField<D>& field, const std::string& path);
template <int D>
VectorField<D> read_vector_field(const std::string& path);

// Copies an image, volume or vector field from `in` to `out` (formats by extension) keeping
// spacing, origin and direction; the voxels go through as float32 (8-bit for .png/.tif/...).
// Bad input throws InputError as read_image does; nothing is written then.
void convert_image_file(const std::string& in, const std::string& out, const ImageWriteOptions& options = {});

}  // namespace dsnake
