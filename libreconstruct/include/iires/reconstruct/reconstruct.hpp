// SPDX-License-Identifier: GPL-3.0-or-later
#pragma once
/// @file reconstruct.hpp
/// @brief The reconstruction pipeline (DESIGN §5): cloud → (isotropic resampling to N) → triangulation
/// (local Delaunay 1-rings or CGAL's advancing front) → small holes closed → large holes (gaps small next to
/// their part) closed with new vertices → consistent orientation → quality report.

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "iires/neighbourhood.hpp"
#include "iires/reconstruct/advancing_front.hpp"
#include "iires/reconstruct/mesh_quality.hpp"
#include "iires/reconstruct/mesh_repair.hpp"
#include "iires/reconstruct/mesh_validity.hpp"
#include "iires/reconstruct/triangulate.hpp"
#include "iires/resample.hpp"
#include "iires/types.hpp"

namespace iires {

/// @brief Triangulation method.
enum class ReconstructMethod {
  kLocal,           ///< tangent-plane Delaunay 1-rings with vertex agreement (triangulate.hpp)
  kAdvancingFront,  ///< CGAL's advancing-front surface reconstruction (advancing_front.hpp)
};

/// @brief "local" or "advancing-front".
std::string toString(ReconstructMethod method);
/// @brief Parse "local" / "advancing-front". @throws std::invalid_argument otherwise.
ReconstructMethod parseReconstructMethod(const std::string& name);

/// @brief The resampler settings reconstruct() starts from: ResampleParams{} with more clean-up passes, a
/// longer final Lloyd relaxation (maxPasses 8 instead of 5, maxRelaxIterations 48 instead of 8; it still stops
/// once the spacing CV stops improving) and the MLS surface of up to 16·N input points instead of 6·N (a finer
/// surface keeps thin parts and small holes). Triangle shape follows the spacing's regularity, so a mesh pays for
/// the longer relaxation.
ResampleParams meshResampling();

/// @brief Parameters of reconstruct().
struct ReconstructParams {
  std::size_t targetCount = 10000;  ///< N, the vertex count of the mesh when resampling (≥ 4)
  bool resample = true;             ///< resample isotropically to N first; false = triangulate the input points
  ReconstructMethod method = ReconstructMethod::kLocal;  ///< triangulation method
  ResampleParams resampling = meshResampling();  ///< resampler settings (targetCount, seed, rule are set from
                                                 ///< here)
  TriangulateParams local;          ///< local method settings (its neighbourRule, when set, is kept, e.g.
                                    ///< EuclideanRule for Euclidean 1-rings after resampling)
  AdvancingFrontParams advancingFront;  ///< advancing-front settings
  std::size_t minComponentFaces = 20;  ///< components with fewer faces are removed before hole filling (0 = keep)
  bool fillHoles = true;            ///< close small holes (loops short in edges and perimeter)
  HoleFillingParams holes;          ///< which loops count as small, and which as a gap for fillLargeHoles()
  /// Triangles with a worse Q are repaired by moving (or else removing) one of their vertices when that does better
  /// and the surface moves by at most repairDeviation × the mean edge length (repairBadTriangles); 0 = off
  double repairQuality = 0.4;
  double repairDeviation = 0.25;    ///< see repairQuality (≥ 0)
  /// Then the regions (2 rings) around triangles still below repairQuality are remeshed isotropically, kept when
  /// their worst Q rises (remeshBadRegions); nothing happens when no triangle is below it
  bool remeshBadRegions = true;
  /// Then the vertices are relaxed tangentially, a move kept where its fan gets better (relaxVertices): sweeps
  /// (0 = off), and how far the surface may move, × the mean edge length
  int relaxSweeps = 3;
  double relaxDeviation = 0.05;
  /// Make the mesh valid after the repairs above (repairValidity): no self-intersection, no non-manifold edge or
  /// vertex; intersecting faces are removed with a neighbourhood and the hole is filled again (when fillHoles)
  bool repairValidity = true;
  ValidityParams validity;          ///< its settings (holes and minComponentFaces are set from here)
  bool evaluate = true;             ///< compute the quality report (distance to the validated input cloud)
  MeshQualityParams quality;        ///< report settings (its seed is set from here)
  /// Neighbour rule for resampling and the 1-rings. nullptr = the resampler's default (intrinsic unless
  /// resampling.intrinsic is false), whose rule the 1-rings then use too; Euclidean 1-rings without resampling.
  std::shared_ptr<NeighbourRule> neighbourRule;
  std::uint64_t seed = 0;  ///< seed of the resampling and the report's mesh sampling; same seed → same mesh

  /// @throws std::invalid_argument with a readable message when a field is out of range.
  void validate() const;
};

/// @brief What reconstruct() produced, with diagnostics.
struct ReconstructResult {
  TriangleMesh mesh;                 ///< the reconstructed mesh, oriented (outward for closed surfaces)
  PointCloud samples;                ///< the points that were triangulated (resampled or the input), with normals
  std::string method;                ///< "local" or "advancing-front"
  std::size_t inputPoints = 0;       ///< points read
  std::size_t nearDuplicatesMerged = 0;  ///< without resampling: points a hair apart merged (validate.hpp)
  bool resampled = false;            ///< whether the input was resampled
  ResampleResult resampling;         ///< the resampler's report (its cloud is moved into samples)
  TriangulateResult triangulation;   ///< the local method's diagnostics (its mesh is moved into mesh)
  std::size_t smallComponentFaces = 0;  ///< faces of small components removed
  HoleFillingReport holes;           ///< small holes closed / kept
  RimBandReport rimBands;            ///< rims of thin parts closed by bands (closeRimBands)
  LargeHoleReport largeHoles;        ///< large holes closed with new vertices / kept (fillLargeHoles)
  std::size_t flipsAfterFilling = 0; ///< Delaunay flips after hole filling (local method)
  BadTriangleReport badTriangles;    ///< vertices moved / removed to raise the worst triangles (repairBadTriangles)
  std::size_t remeshedVertices = 0;  ///< vertices moved / removed / added by remeshBadRegions
  std::size_t verticesRelaxed = 0;   ///< vertices moved by relaxVertices
  ValidityReport validity;           ///< what repairValidity found and did
  OrientationReport orientation;     ///< orientation diagnostics
  std::size_t unusedVertices = 0;    ///< samples no triangle uses (removed from the mesh)
  MeshQuality quality;               ///< the quality report (when params.evaluate)
  PointCloud uncoveredInput;         ///< input points the mesh does not cover (quality.uncoveredPoints)
  std::vector<StageTime> timings;    ///< per stage, in order; the last is "total"

  /// @brief Seconds spent meshing after resampling (triangulation, holes, validity repair, orientation).
  double meshingSeconds() const;
  /// @brief The report as a JSON object.
  std::string toJson() const;
};

/// @brief Reconstruct a triangle mesh from @p input.
/// @throws InputError for an unusable cloud (empty, NaN, fewer than 4 distinct points, collinear);
/// std::invalid_argument for bad parameters.
/// @note Deterministic: same input, params and seed give the same mesh for any thread count.
/// @param exec threads and progress reports: the resampler's stages (see resample()), then "normals" (no
/// resampling), "triangulate", "holes", "validity", "orient", "quality"
ReconstructResult reconstruct(const PointCloud& input, const ReconstructParams& params = {}, const Execution& exec = {});

}  // namespace iires
