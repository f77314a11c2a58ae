#include "libcommon/math.h"

namespace iris {

Transform Transform::inverse() const {
    double a[4][8];
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) {
            a[i][j] = m[i][j];
            a[i][j + 4] = (i == j) ? 1.0 : 0.0;
        }
    for (int c = 0; c < 4; ++c) {
        int piv = c;
        for (int r = c + 1; r < 4; ++r)
            if (std::abs(a[r][c]) > std::abs(a[piv][c])) piv = r;
        if (a[piv][c] == 0.0) return Transform();  // singular: callers validate determinants first
        if (piv != c)
            for (int j = 0; j < 8; ++j) std::swap(a[c][j], a[piv][j]);
        double inv = 1.0 / a[c][c];
        for (int j = 0; j < 8; ++j) a[c][j] *= inv;
        for (int r = 0; r < 4; ++r) {
            if (r == c) continue;
            double f = a[r][c];
            if (f == 0.0) continue;
            for (int j = 0; j < 8; ++j) a[r][j] -= f * a[c][j];
        }
    }
    Transform r;
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) r.m[i][j] = a[i][j + 4];
    return r;
}

Transform Transform::transpose() const {
    Transform r;
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) r.m[i][j] = m[j][i];
    return r;
}

Vec3 Transform::normal(Vec3 n) const {
    Transform it = inverse().transpose();
    return normalize(it.vector(n));
}

double Transform::determinant3x3() const {
    return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
           m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

Transform Transform::translate(Vec3 t) {
    Transform r;
    r.m[0][3] = t.x;
    r.m[1][3] = t.y;
    r.m[2][3] = t.z;
    return r;
}

Transform Transform::scale(Vec3 s) {
    Transform r;
    r.m[0][0] = s.x;
    r.m[1][1] = s.y;
    r.m[2][2] = s.z;
    return r;
}

Transform Transform::rotate(Vec3 axis, double degrees) {
    double len = std::sqrt(double(axis.x) * axis.x + double(axis.y) * axis.y + double(axis.z) * axis.z);
    double x = axis.x / len, y = axis.y / len, z = axis.z / len;
    double th = degrees * 3.14159265358979323846 / 180.0;
    double c = std::cos(th), s = std::sin(th), t = 1 - c;
    Transform r;
    r.m[0][0] = t * x * x + c;     r.m[0][1] = t * x * y - s * z; r.m[0][2] = t * x * z + s * y;
    r.m[1][0] = t * x * y + s * z; r.m[1][1] = t * y * y + c;     r.m[1][2] = t * y * z - s * x;
    r.m[2][0] = t * x * z - s * y; r.m[2][1] = t * y * z + s * x; r.m[2][2] = t * z * z + c;
    return r;
}

Transform Transform::look_at(Vec3 origin, Vec3 target, Vec3 up) {
    Vec3 dir = normalize(target - origin);
    Vec3 left = normalize(cross(normalize(up), dir));
    Vec3 new_up = cross(dir, left);
    Transform r;
    Vec3 cols[4] = {left, new_up, dir, origin};
    for (int c = 0; c < 4; ++c) {
        r.m[0][c] = cols[c].x;
        r.m[1][c] = cols[c].y;
        r.m[2][c] = cols[c].z;
    }
    return r;
}

}  // namespace iris
