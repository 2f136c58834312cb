// SPDX-License-Identifier: GPL-3.0-or-later
#include "iires/reconstruct/reconstruct.hpp"

#include <Eigen/Geometry>

#include <chrono>
#include <cmath>
#include <stdexcept>

#include "iires/attributes.hpp"
#include "iires/detail/json.hpp"
#include "iires/detail/parallel.hpp"
#include "iires/detail/stage_clock.hpp"
#include "iires/intrinsic.hpp"
#include "iires/normals.hpp"
#include "iires/reconstruct/mesh_validity.hpp"
#include "iires/sheets.hpp"
#include "iires/validate.hpp"

namespace iires {
namespace {

using Clock = std::chrono::steady_clock;

}  // namespace

std::string toString(ReconstructMethod method) {
  return method == ReconstructMethod::kLocal ? "local" : "advancing-front";
}

ReconstructMethod parseReconstructMethod(const std::string& name) {
  if (name == "local") return ReconstructMethod::kLocal;
  if (name == "advancing-front") return ReconstructMethod::kAdvancingFront;
  throw std::invalid_argument("unknown method '" + name + "' (expected local or advancing-front)");
}

ResampleParams meshResampling() {
  ResampleParams p;
  p.maxPasses = 8;
  p.maxRelaxIterations = 48;
  p.maxInputPerSample = 16;
  return p;
}

void ReconstructParams::validate() const {
  if (resample && targetCount < 4)
    throw std::invalid_argument("target count N must be at least 4 (got " + std::to_string(targetCount) + ")");
  if (!(repairQuality >= 0 && repairQuality < 1)) throw std::invalid_argument("repairQuality must be in [0, 1)");
  if (relaxSweeps < 0) throw std::invalid_argument("relaxSweeps must be >= 0");
  if (!(relaxDeviation >= 0)) throw std::invalid_argument("relaxDeviation must be non-negative");
  if (!(repairDeviation >= 0)) throw std::invalid_argument("repairDeviation must be non-negative");
  ResampleParams r = resampling;
  r.targetCount = std::max<std::size_t>(targetCount, 1);
  if (resample) r.validate();
  local.validate();
  validity.validate();
  advancingFront.validate();
  holes.validate();
  quality.validate();
}

double ReconstructResult::meshingSeconds() const {
  double s = 0;
  for (const auto& t : timings)
    if (t.name == "triangulate" || t.name == "holes" || t.name == "validity" || t.name == "orient") s += t.seconds;
  return s;
}

std::string ReconstructResult::toJson() const {
  detail::JsonWriter j;
  j.beginObject(true).member("method", method).member("input_points", inputPoints).member("resampled", resampled);
  if (!resampled) j.member("near_duplicates_merged", nearDuplicatesMerged);
  j.member("samples", samples.size()).member("mesh_vertices", mesh.vertices.size());
  j.member("mesh_faces", mesh.triangles.size()).member("unused_samples", unusedVertices);
  j.member("small_component_faces_removed", smallComponentFaces);
  if (resampled) j.key("resampling").embed(resampling.toJson());
  if (method == "local") {
    j.key("triangulation").beginObject().member("candidates", triangulation.candidates);
    j.member("proposed_by_3", triangulation.proposedBy3).member("proposed_by_2", triangulation.proposedBy2);
    j.member("kept", triangulation.kept).member("rejected_conflicts", triangulation.rejectedConflicts);
    j.member("removed_fan_faces", triangulation.removedFans).member("flips", triangulation.flips);
    j.member("normals_turned", triangulation.normalsTurned);
    j.member("flips_after_filling", flipsAfterFilling).endObject();
  }
  j.key("bad_triangles").beginObject().member("vertices_moved", badTriangles.moved);
  j.member("vertices_removed", badTriangles.removed).member("remeshed_vertices", remeshedVertices);
  j.member("rim_faces_peeled", badTriangles.peeled).endObject();
  j.member("vertices_relaxed", verticesRelaxed);
  const auto holeCounts = [&](std::string_view name, const auto& h) {
    j.key(name).beginObject().member("loops", h.loops).member("filled", h.filled).member("kept", h.kept);
    j.member("faces_added", h.facesAdded).member("vertices_added", h.verticesAdded);
  };
  holeCounts("holes", holes);
  j.endObject();
  j.key("rim_bands").beginObject().member("bands", rimBands.bands).member("faces_added", rimBands.facesAdded);
  j.member("parts_turned", rimBands.partsTurned).endObject();
  holeCounts("large_holes", largeHoles);
  j.member("unsupported", largeHoles.unsupported).member("faces_left_out", largeHoles.facesLeftOut).endObject();
  j.key("validity_repair").beginObject().member("intersecting_pairs_found", validity.intersectingPairs);
  j.member("non_manifold_edges_found", validity.nonManifoldEdges).member("rounds", validity.rounds);
  j.member("faces_removed", validity.facesRemoved).member("faces_added", validity.facesAdded);
  j.member("vertices_added", validity.verticesAdded).member("removed_without_fill", validity.removedWithoutFill);
  j.endObject();
  j.key("orientation").beginObject().member("components", orientation.components);
  j.member("faces_flipped", orientation.facesFlipped).member("conflicts", orientation.conflicts).endObject();
  j.key("quality").embed(quality.toJson()).member("meshing_time_s", meshingSeconds());
  j.key("time_s").beginObject();
  for (const StageTime& t : timings) j.member(t.name, t.seconds);
  j.endObject().endObject();
  return j.str() + "\n";
}

namespace {
/// Area-weighted unit vertex normals of an oriented mesh (zero for vertices without faces).
std::vector<Eigen::Vector3d> vertexNormals(const TriangleMesh& mesh) {
  std::vector<Eigen::Vector3d> n(mesh.vertices.size(), Eigen::Vector3d::Zero());
  for (const Eigen::Vector3i& t : mesh.triangles) {
    const Eigen::Vector3d& a = mesh.vertices[t[0]];
    const Eigen::Vector3d f = (mesh.vertices[t[1]] - a).cross(mesh.vertices[t[2]] - a);
    for (int k = 0; k < 3; ++k) n[t[k]] += f;
  }
  for (Eigen::Vector3d& v : n)
    if (v.squaredNorm() > 0) v.normalize();
  return n;
}

/// The samples: the input resampled to params.targetCount (result.resampling), else the input points as they
/// are, with PCA normals when it has none.
void takeSamples(const PointCloud& cloud, const ReconstructParams& params, const Execution& exec,
                 ReconstructResult& result) {
  if (params.resample) {
    ResampleParams rp = params.resampling;
    rp.targetCount = params.targetCount;
    rp.seed = params.seed;
    if (params.neighbourRule) rp.neighbourRule = params.neighbourRule;
    result.resampling = resample(cloud, rp, exec);
    result.samples = std::move(result.resampling.cloud);
    result.resampling.cloud = PointCloud{};
    result.resampled = true;
    return;
  }
  result.samples = cloud;
  if (!result.samples.hasNormals()) {
    result.samples.normals = estimateNormals(result.samples.points, params.resampling.normals, exec);
  }
  for (auto& n : result.samples.normals) n.normalize();
}

/// The mesh of the samples: local Delaunay 1-rings (with the resampler's intrinsic rule unless a neighbour
/// rule is given) or CGAL's advancing front.
void triangulateSamples(const ReconstructParams& params, const Execution& exec, ReconstructResult& result) {
  if (params.method == ReconstructMethod::kLocal) {
    TriangulateParams tp = params.local;
    if (params.neighbourRule) {
      tp.neighbourRule = params.neighbourRule;
    } else if (!tp.neighbourRule && result.resampling.geodesic) {
      // The resampler's intrinsic rule (DESIGN §5.2): 1-rings never link across a thin gap or between objects.
      tp.neighbourRule =
          std::make_shared<IntrinsicRule>(result.resampling.geodesic, params.resampling.intrinsicRule, exec,
                                          result.resampling.nearSheets);
    }
    // The sheet rule's pair test (sheets.hpp) on the samples where the rule found another sheet near on the
    // dense cloud: two sheets closer than the samples' spacing, which the dense cloud resolves (its spacing sets
    // the gap), are not linked — geodesic coordinates from satellites equidistant from both (a thin plate's
    // corners) do not tell them apart.
    const GeodesicCoordinates* geo = result.resampling.geodesic.get();
    const std::vector<std::uint8_t>& near = result.resampling.nearSheets;
    if (tp.sheetGap == 0 && geo && near.size() == geo->size() && result.resampling.sheets.nearPoints > 0) {
      const SheetParams& sheet = params.resampling.preprocessing.sheet;
      tp.sheetGap = sheet.gapSpacings * geo->spacing();
      tp.sheetGapAngleDeg = sheet.gapAngleDeg;
      tp.sheetNear.assign(result.samples.size(), 0);
      parallelFor(result.samples.size(), exec.threads, [&](std::size_t i) {  // each sample's nearest dense point
        const std::int64_t d = geo->nearest(result.samples.points[i]);
        tp.sheetNear[i] = d >= 0 && near[static_cast<std::size_t>(d)];
      });
    }
    result.triangulation = triangulateLocal(result.samples, tp, exec);
    result.mesh = std::move(result.triangulation.mesh);
    result.triangulation.mesh = TriangleMesh{};
    result.samples.normals = std::move(result.triangulation.normals);  // as the mesh is oriented
    result.triangulation.normals.clear();
  } else {
    result.mesh = advancingFront(result.samples, params.advancingFront).mesh;
  }
}

/// params.holes, with the resampler's working cloud (the dense input its geodesic coordinates hold) as the input
/// large-hole fills must lie on, when the input was resampled and params.holes names no input of its own.
HoleFillingParams holeParams(const ReconstructParams& params, const ReconstructResult& result) {
  HoleFillingParams holes = params.holes;
  if (!holes.inputPoints && result.resampling.geodesic) {  // the dense cloud, owned by its geodesic coordinates
    const std::shared_ptr<const GeodesicCoordinates> geo = result.resampling.geodesic;
    holes.inputPoints = std::make_shared<const SampledPoints>(
        std::shared_ptr<const std::vector<Eigen::Vector3d>>(geo, &geo->points()), [geo] { return geo->edges(); });
  }
  return holes;
}

/// Small components removed, small holes closed (again after removing the fans a fill pinched together), large
/// holes closed (@p holes: params.holes with the input, see holeParams), edges flipped back to Delaunay, bad
/// triangles repaired, the vertices relaxed. Returns the faces flipped by the orientation passes
/// that large holes and remeshing need first.
std::size_t closeHoles(const ReconstructParams& params, const HoleFillingParams& holes, const Execution& exec,
                       ReconstructResult& result, std::vector<Eigen::Vector3d>& normals) {
  std::size_t flipped = 0;
  if (params.minComponentFaces > 1) result.smallComponentFaces = removeSmallComponents(result.mesh, params.minComponentFaces);
  if (params.fillHoles) {
    result.holes = fillSmallHoles(result.mesh, normals, params.holes);
    // A filled loop can pinch two sheets together at a vertex: drop the smaller fan there, and close again.
    if (removeExtraFans(result.mesh, exec.threads) > 0) {
      if (params.minComponentFaces > 1)
        result.smallComponentFaces += removeSmallComponents(result.mesh, params.minComponentFaces);
      const HoleFillingReport again = fillSmallHoles(result.mesh, normals, params.holes);
      result.holes.loops += again.loops;
      result.holes.filled += again.filled;
      result.holes.kept = again.kept;
      result.holes.facesAdded += again.facesAdded;
      result.holes.verticesAdded += again.verticesAdded;
    }
    if (result.holes.kept > 0 && (holes.inputPoints || params.holes.maxRefinedExtent > 0)) {
      // What is left open: the rims of parts thinner than the edges get bands, and a gap small next to its part
      // a refined fill (both need an oriented 2-manifold).
      flipped += orientConsistently(result.mesh, normals).facesFlipped;
      result.rimBands = closeRimBands(result.mesh, normals, holes);
      if (params.holes.maxRefinedExtent > 0) result.largeHoles = fillLargeHoles(result.mesh, normals, holes);
    }
    if (params.method == ReconstructMethod::kLocal && params.local.flipMaxDihedral > 0 &&
        (result.holes.facesAdded || result.rimBands.bands || result.largeHoles.filled))
      result.flipsAfterFilling = flipToDelaunay(result.mesh, params.local.flipMaxDihedral, params.local.maxFlipSweeps);
  }
  if (params.repairQuality > 0) {
    result.badTriangles = repairBadTriangles(result.mesh, normals, params.repairQuality, params.repairDeviation);
    if (params.remeshBadRegions) {
      flipped += orientConsistently(result.mesh, normals).facesFlipped;  // remeshing needs it oriented
      result.remeshedVertices = remeshBadRegions(result.mesh, normals, params.repairQuality);
    }
    result.badTriangles.peeled = peelRimSlivers(result.mesh, params.repairQuality);
  }
  result.verticesRelaxed = relaxVertices(result.mesh, normals, params.relaxSweeps, params.relaxDeviation);
  return flipped;
}

/// Whether a face of @p mesh has a quality under @p q (remeshBadRegions() has work).
bool anyFaceBelow(const TriangleMesh& mesh, double q) {
  const auto& P = mesh.vertices;
  return std::any_of(mesh.triangles.begin(), mesh.triangles.end(), [&](const Eigen::Vector3i& t) {
    return triangleQuality(P[static_cast<std::size_t>(t[0])], P[static_cast<std::size_t>(t[1])],
                           P[static_cast<std::size_t>(t[2])]) < q;
  });
}

/// Self-intersecting faces and non-manifold parts removed (and refilled); the fills' poor triangles repaired,
/// then checked again. Returns the faces flipped by the orientation passes remeshing needs first.
std::size_t repairMeshValidity(const ReconstructParams& params, const HoleFillingParams& holes, const Execution& exec,
                               ReconstructResult& result, std::vector<Eigen::Vector3d>& normals) {
  std::size_t flipped = 0;
  ValidityParams vp = params.validity;
  vp.holes = holes;
  vp.refill = params.fillHoles && vp.refill;
  vp.minComponentFaces = params.minComponentFaces;
  vp.onlyOpenedLoops = true;  // closeHoles() looked at the others
  vp.unseenLoops = result.largeHoles.unseen;
  result.validity = repairValidity(result.mesh, normals, vp, exec);
  if (result.validity.facesAdded > 0 && params.repairQuality > 0) {
    const TriangleMesh clean = result.mesh;
    // The fills can hold poor triangles: the same quality repairs as above, then the check again (a repair that
    // made something intersect is undone by removal there).
    const BadTriangleReport again = repairBadTriangles(result.mesh, normals, params.repairQuality, params.repairDeviation);
    result.badTriangles.moved += again.moved;
    result.badTriangles.removed += again.removed;
    if (params.remeshBadRegions && anyFaceBelow(result.mesh, params.repairQuality)) {
      flipped += orientConsistently(result.mesh, normals).facesFlipped;
      result.remeshedVertices += remeshBadRegions(result.mesh, normals, params.repairQuality);
    }
    result.badTriangles.peeled += peelRimSlivers(result.mesh, params.repairQuality);
    if (result.mesh.triangles != clean.triangles || result.mesh.vertices != clean.vertices) {  // a repair ran
      vp.rounds = 1;
      const ValidityReport check = repairValidity(result.mesh, normals, vp, exec, &clean);
      result.validity.rounds += check.rounds;
      result.validity.facesRemoved += check.facesRemoved;
      result.validity.facesAdded += check.facesAdded;
      result.validity.verticesAdded += check.verticesAdded;
      result.validity.removedWithoutFill += check.removedWithoutFill;
    }
  }
  return flipped;
}

/// The input's attributes interpolated at the mesh vertices, from input points on the same sheet.
void carryAttributes(const PointCloud& input, const ReconstructParams& params, const Execution& exec,
                     ReconstructResult& result) {
  SameSheet sameSheet;  // the resampler's intrinsic rule: vertices take values from input points on their sheet
  std::shared_ptr<const IntrinsicRule> rule;
  if (result.resampling.geodesic) {
    rule = std::make_shared<IntrinsicRule>(result.resampling.geodesic, params.resampling.intrinsicRule, exec,
                                          result.resampling.nearSheets);
    sameSheet = [&rule](const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return rule->acceptPoints(a, b); };
  }
  result.mesh.vertexAttributes =
      interpolateAttributes(input, result.mesh.vertices, vertexNormals(result.mesh), sameSheet, {}, exec);
}

}  // namespace

ReconstructResult reconstruct(const PointCloud& input, const ReconstructParams& params, const Execution& exec) {
  params.validate();
  exec.validate();
  const auto start = Clock::now();
  ReconstructResult result;
  result.method = toString(params.method);
  result.inputPoints = input.size();
  const StageClock clock(result.timings, exec.progress);  // the resampler reports its own stages

  auto t = clock.begin("validate");
  PointCloud cloud;  // positions and normals; the attributes are carried to the vertices at the end
  cloud.points = input.points;
  cloud.normals = input.normals;
  validateCloud(cloud, 4, "input", exec.threads);
  if (!params.resample) {  // resample() does both itself
    result.nearDuplicatesMerged = mergeNearDuplicates(cloud, exec.threads);
    checkSamplesASurface(cloud.points, "input", exec.threads);
  }
  clock.end("validate", t);

  t = params.resample ? Clock::now() : clock.begin("normals");
  takeSamples(cloud, params, exec, result);
  clock.end(params.resample ? "resample" : "normals", t);

  t = clock.begin("triangulate");
  triangulateSamples(params, exec, result);
  clock.end("triangulate", t);

  t = clock.begin("holes");
  std::vector<Eigen::Vector3d> normals = result.samples.normals;  // grows with any vertex hole filling adds
  const HoleFillingParams holes = holeParams(params, result);  // one input index for every pass
  std::size_t flippedEarlier = closeHoles(params, holes, exec, result, normals);  // by orientation passes needed first
  clock.end("holes", t);

  if (params.repairValidity) {
    t = clock.begin("validity");
    flippedEarlier += repairMeshValidity(params, holes, exec, result, normals);
    clock.end("validity", t);
  }

  t = clock.begin("orient");
  result.orientation = orientConsistently(result.mesh, normals);
  result.orientation.facesFlipped += flippedEarlier;  // the earlier passes' flips (before large holes, remeshing)
  const std::size_t before = result.mesh.vertices.size();
  removeUnusedVertices(result.mesh);
  result.unusedVertices = before - result.mesh.vertices.size();
  clock.end("orient", t);

  if (!input.attributes.empty()) {
    t = clock.begin("attributes");
    carryAttributes(input, params, exec, result);
    clock.end("attributes", t);
  }

  if (params.evaluate) {
    t = clock.begin("quality");
    MeshQualityParams qp = params.quality;
    qp.seed = params.seed + 1;
    result.quality = evaluateMesh(result.mesh, &cloud, qp, exec);
    result.uncoveredInput = uncoveredInput(cloud, result.quality);
    clock.end("quality", t);
  }
  clock.end("total", start);
  return result;
}

}  // namespace iires
