// Build plates and exact sharding.
//
// A plate is a job with [[part]] tables (job/job.hpp PlatePart): every part has its own design,
// its own settings over the job's and a placement (x, y of its footprint's centre, rotation about
// z). The parts are checked against the machine's build area (inside it, at least
// `clearance` mm apart) before any layer is computed; plate layer i holds layer i of every part
// that is that tall, parts in the order of the job file.
//
// Sharding: `trellis run JOB --shard K/N` computes layers [a, b) only — the ranges balance the
// estimated work per layer — and writes the shard's layers (a binary dump of the toolpath IR,
// exact doubles) plus a small JSON manifest. `trellis merge MANIFESTS… -o OUT` checks the
// manifests (one job, shards 1..N each once, contiguous layers), joins the layers and runs the
// single-process writer on them, so the merged file is byte for byte the file of the
// single-process run: headers, layer counts, dimensions, E axis and time estimates all come
// from the same writer on the same toolpath.
#pragma once
#include <array>
#include <string>
#include <utility>
#include <vector>

#include "trellis/core/vec.hpp"
#include "trellis/job/job.hpp"
#include "trellis/machine/toolpath_3mf.hpp"
#include "trellis/toolpath/toolpath.hpp"

namespace trellis {

// The rectangle a part covers on the plate: its design's XY extent rotated and placed.
struct PartFootprint {
  std::string label;
  long line = 0;                // in the job file
  std::array<Vec2, 4> corners;  // counter-clockwise
};

// The footprint of a design extent `box` placed as `part` says.
PartFootprint place_footprint(const PlatePart& part, const BBox3& box);
// A design point moved to the plate: rotated about the extent's XY centre, then moved so that
// centre lands on (part.x, part.y).
Vec3 place_point(const PlatePart& part, const BBox3& box, Vec3 p);
// The same placement as a 3MF build item's transform (machine/toolpath_3mf.hpp), z moved by `dz`:
// apply_transform(place_transform(part, box, dz), p) = place_point(part, box, p) + (0, 0, dz).
Transform3mf place_transform(const PlatePart& part, const BBox3& box, double dz = 0);

// Every footprint inside `area` and every pair at least `clearance` apart, else SettingError
// (exit 2) naming the parts, their lines in `origin` and by how much.
void check_plate(const std::vector<PartFootprint>& parts, const BBox2& area, double clearance,
                 const std::string& origin);

// A plate printed part by part (plate.sequence = parts), in the order of `parts`: the machine's
// extruder clearance must be known (radius and height > 0); every part but the last at most
// `clearance_height` tall (`heights`, mm; the gantry passes over finished parts); every two parts
// at least `clearance_radius` apart. Else SettingError (exit 2) naming the parts.
void check_sequential(const std::vector<PartFootprint>& parts, const std::vector<double>& heights,
                      double clearance_radius, double clearance_height, const std::string& origin);

// "K/N" (1 <= K <= N) → {K, N}; SettingError otherwise.
std::pair<int, int> parse_shard(const std::string& text);
// Layer range [a, b) of shard k (1-based) of n: contiguous, in order, splitting the total of
// `work` (estimated work per layer, >= 0) as evenly as whole layers allow.
std::pair<std::size_t, std::size_t> shard_range(const std::vector<double>& work, int k, int n);

// The data file of shard k of n of `output`: OUTPUT.shard-K-of-N (its manifest adds ".json").
std::string shard_name(const std::string& output, int k, int n);
// Shard files: the toolpath layers of one shard, exact (binary doubles).
std::string shard_bytes(const std::vector<Layer>& layers);
std::vector<Layer> layers_from_shard_bytes(const std::string& bytes, const std::string& origin);

// Writes the shard of `job` (job.shard of job.shards): `layers` (its range [first, first +
// layers.size()) of `total` layers) next to job.output as OUTPUT.shard-K-of-N plus the manifest
// OUTPUT.shard-K-of-N.json, through write_file_atomic. Returns the manifest's path. A graded
// slicing shard (layers before the whole-print step, slice/pipeline.hpp finish_graded) gives
// `graded_json`, a JSON object the manifest keeps as "graded" (version 3) for the merge.
std::string write_shard(const Job& job, const std::vector<Layer>& layers, std::size_t first,
                        std::size_t total, const std::string& source,
                        const std::vector<std::string>& part_labels,
                        const std::string& graded_json = {});

// `trellis merge`: the manifests' layers joined and written to `output` by the route's own
// writer. Exit-2 errors (nothing written) for manifests of different jobs, a shard missing or
// given twice, a shard file that does not match its manifest, or an output that is one of the
// shards' files (RunFiles, with `follow_symlinks`).
JobResult merge_shards(const std::vector<std::string>& manifests, const std::string& output,
                       Diagnostics& diag, bool follow_symlinks = false);

}  // namespace trellis
