// Internal to the image I/O: DICOM through GDCM (framework/io/dicom.cpp). GDCM stays inside
// dicom.cpp; this header names no GDCM type. Not part of the API (see image_io.h).
#pragma once

#include "framework/io/image_io_detail.h"

#include <string>

namespace dsnake::detail {

// True if `path` is meant as DICOM: a folder (a series), "folder#SeriesInstanceUID", a .dcm or
// .dicom file, or any file with the "DICM" magic at byte 128.
bool is_dicom_path(const std::string& path);

// A single DICOM file (2D; a multi-frame file 3D) or one series in a folder (3D), decoded by
// GDCM, rescaled (RescaleSlope/RescaleIntercept) and, for a series, sorted along the slice
// normal. InputError naming the file or folder for anything it cannot read.
RawVolume read_dicom(const std::string& path);

// 2 or 3 from the headers only (a single-frame file or a one-slice series is 2D).
int dicom_dimension(const std::string& path);

}  // namespace dsnake::detail
