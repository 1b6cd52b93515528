#include "contact/convex_hull.hpp"

#include <cstdio>
#include <cstdlib>
#include <vector>

extern "C" {
#include <libqhull_r/qhull_ra.h>
}

#include "framework/error.hpp"

namespace sweep {

std::shared_ptr<TriangleMesh> convexHull(const TriangleMesh& mesh, const std::string& where) {
  const int n = static_cast<int>(mesh.vertices.size());
  for (const Vector3& p : mesh.vertices)
    if (!p.allFinite()) throw InputError(where + ": a vertex is not finite: no convex hull");
  if (n < 4)
    throw InputError(where + ": " + std::to_string(n) +
                     " vertices span no volume: a convex hull needs four not on one plane");
  std::vector<coordT> points(3 * static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i)
    for (int k = 0; k < 3; ++k) points[3 * i + k] = mesh.vertices[i][k];

  // Qhull writes its diagnostics to a stream: kept in memory for the error message
  char* message = nullptr;
  std::size_t message_size = 0;
  FILE* errors = open_memstream(&message, &message_size);
  qhT context;
  qhT* qh = &context;
  qh_zero(qh, errors);
  // Qt: triangulated output (merged coplanar facets split into triangles)
  char options[] = "qhull Qt";
  const int status = qh_new_qhull(qh, 3, n, points.data(), False, options, nullptr, errors);

  auto hull = std::make_shared<TriangleMesh>();
  if (status == 0) {
    std::vector<int> index(n, -1);
    facetT* facet;
    FORALLfacets {
      if (facet->upperdelaunay || qh_setsize(qh, facet->vertices) != 3) continue;
      std::array<int, 3> triangle{};
      int k = 0;
      vertexT *vertex, **vertexp;
      FOREACHvertex_(facet->vertices) {
        const int id = qh_pointid(qh, vertex->point);
        if (index[id] < 0) {
          index[id] = static_cast<int>(hull->vertices.size());
          hull->vertices.push_back(mesh.vertices[id]);
        }
        triangle[k++] = index[id];
      }
      // Qhull's vertex order says nothing of the side: turn each triangle to its facet's
      // outward normal
      const Vector3 normal(facet->normal[0], facet->normal[1], facet->normal[2]);
      const Vector3 a = hull->vertices[triangle[0]];
      if ((hull->vertices[triangle[1]] - a).cross(hull->vertices[triangle[2]] - a).dot(normal) <
          0.0)
        std::swap(triangle[1], triangle[2]);
      hull->triangles.push_back(triangle);
    }
  }
  qh_freeqhull(qh, !qh_ALL);
  int still_long = 0, total_long = 0;
  qh_memfreeshort(qh, &still_long, &total_long);
  std::fclose(errors);
  const std::string text = message ? message : "";
  std::free(message);
  if (status != 0 || hull->triangles.size() < 4) {
    // Qhull's first line names the cause (a flat or degenerate input: QH6154, QH6214 ...)
    const std::string first = text.substr(0, text.find('\n'));
    throw InputError(where + ": its vertices span no volume, no convex hull" +
                     (first.empty() ? std::string() : " (Qhull: " + first + ")"));
  }
  return hull;
}

}  // namespace sweep
