// The image targets' common step: the bytes as an image file named `name`, read as `dsnake`
// reads an image (its dimension from the header, then the reader of that dimension).
#pragma once

#include "framework/io/image_io.h"
#include "tests/fuzz/fuzz_support.h"

namespace dsnake::fuzz {

inline void read_image_file(const uint8_t* data, size_t size, const std::string& name) {
  const std::string path = write_input(data, size, name);
  expect_input_errors_only([&] {
    if (image_file_dimension(path) == 2) read_image<2>(path);
    else read_image<3>(path);
  });
}

}  // namespace dsnake::fuzz
