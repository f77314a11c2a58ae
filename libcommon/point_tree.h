// A k-d tree over a flat array of 3D points (nanoflann), used for photon gathering (fill-caches) and
// cache lookup (render). The points are referenced, not copied: keep the array alive and unchanged.
#pragma once

#include <nanoflann.hpp>

#include <cstdint>
#include <vector>

#include "libcommon/math.h"

namespace iris {

class PointTree {
public:
    explicit PointTree(const std::vector<Vec3>& points)
        : cloud_{&points}, index_(3, cloud_, nanoflann::KDTreeSingleIndexAdaptorParams(16)) {
        index_.buildIndex();
    }
    PointTree(const PointTree&) = delete;
    PointTree& operator=(const PointTree&) = delete;

    size_t size() const { return cloud_.points->size(); }

    // The up to k nearest points to q with squared distance below max_dist2, nearest first.
    // `indices` and `dist2` must hold k entries; returns how many were found.
    uint32_t nearest(Vec3 q, uint32_t k, float max_dist2, uint32_t* indices, float* dist2) const {
        if (k == 0 || size() == 0) return 0;
        nanoflann::KNNResultSet<float, uint32_t> result(k);
        result.init(indices, dist2);
        // KNNResultSet prunes against its last slot: seeding it with the radius bounds the search.
        dist2[k - 1] = max_dist2;
        const float query[3] = {q.x, q.y, q.z};
        index_.findNeighbors(result, query, nanoflann::SearchParams(32, 0.0f, true));
        return uint32_t(result.size());
    }

    // All points with squared distance below r2, unsorted, into `out` (cleared first). For large k this
    // beats nearest(): nanoflann's k-nearest result set inserts in O(k), so k = 2000 costs O(k^2).
    void within(Vec3 q, float r2, std::vector<std::pair<uint32_t, float>>& out) const {
        out.clear();
        if (size() == 0) return;
        nanoflann::RadiusResultSet<float, uint32_t> result(r2, out);
        const float query[3] = {q.x, q.y, q.z};
        index_.findNeighbors(result, query, nanoflann::SearchParams(32, 0.0f, false));
    }

private:
    struct Cloud {
        const std::vector<Vec3>* points;
        size_t kdtree_get_point_count() const { return points->size(); }
        float kdtree_get_pt(size_t i, size_t dim) const { return (*points)[i][int(dim)]; }
        template <class BBox>
        bool kdtree_get_bbox(BBox&) const { return false; }
    };
    using Index = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, Cloud>, Cloud, 3, uint32_t>;
    Cloud cloud_;
    Index index_;
};

}  // namespace iris
