// result.json's "pose": where the run moved the template as a whole. A registration that is
// right in shape but slid away is wrong; a start on the true surface must stay there (the
// fixed-point check). The centroid is the enclosed region's (framework/core/alignment.h),
// exact for the polygon or mesh, so remeshing does not move it.
#pragma once

#include "framework/core/image.h"
#include "framework/core/shape.h"

#include <nlohmann/json.hpp>

namespace dsnake {

// {"centroid_start": [..], "centroid_end": [..] (world mm), "centroid_shift": |end - start| (mm),
//  "measure_ratio": end's area/volume over start's}.
template <int D>
nlohmann::ordered_json pose_json(const Snake<D>& start, const Snake<D>& end, const Grid<D>& frame);

}  // namespace dsnake
