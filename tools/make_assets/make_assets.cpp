// Generates the default appearance assets (share/assets): simple shaded 3D models of a car, a truck, a bus
// and a pedestrian, ray-cast from sixteen viewpoints into PNGs with alpha, plus the assets.yaml index.
//
//   hf_make_assets --out share/assets [--height 240] [--only car]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "hazardforge/assets/asset_library.hpp"
#include "hazardforge/assets/box_geometry.hpp"
#include "hazardforge/error.hpp"

namespace {

using cv::Vec3d;
namespace fs = std::filesystem;
namespace hr = hf::render;

// The fine detail a surface carries at the scale of a few picture pixels: what makes a real car or person
// look sharp next to a flat-shaded model (docs/augmentation.md, realism: sharpness).
enum class Pattern {
  none,
  paint,   // road grime towards the sills
  plate,   // a registration: a row of dark characters centred on `centre` (y, z), `size` = character height
  lamp,    // horizontal ribs and a brighter reflector in a lamp cluster
  tread,   // tyre grooves around the circumference, the sidewall's moulding
  spokes,  // five spokes of a wheel centred on (x = `centre`[0], z = `centre`[2])
  fabric,  // folds and seams of clothing; a zip down the front
  denim,   // a trouser leg's creases and outer seam
  hair,    // strands
  face,    // eyes, brows and mouth on a head centred on `centre`
  seat,    // a seat's quilting, seen through the glass
};

struct Material {
  Vec3d albedo;            // BGR, 0..1
  double specular = 0.0;   // strength of the sky reflection
  double emissive = 0.0;   // lamps: part of the colour that ignores shading
  double transmits = 0.0;  // glass: share of the cabin behind it that shows through
  Pattern pattern = Pattern::none;
  Vec3d centre;       // the pattern's anchor in the object frame
  double size = 0.0;  // the pattern's scale in metres
};

struct Hit {
  double t = 1e30;
  Vec3d n;
  int material = -1;
};

// Deterministic value noise for the surface detail: the same picture on every run and machine.
uint32_t mix32(uint32_t h) {
  h ^= h >> 16;
  h *= 0x7feb352dU;
  h ^= h >> 15;
  h *= 0x846ca68bU;
  h ^= h >> 16;
  return h;
}
double cell(int x, int y, int z = 0) {
  const uint32_t h =
      mix32(static_cast<uint32_t>(x) * 73856093U ^
            mix32(static_cast<uint32_t>(y) * 19349663U ^ mix32(static_cast<uint32_t>(z) * 83492791U)));
  return h / 4294967295.0;
}
double smooth(double t) {
  return t * t * (3 - 2 * t);
}
// Trilinear value noise in 0..1 with a period of one unit.
double noise3(const Vec3d& p) {
  const double fx = std::floor(p[0]), fy = std::floor(p[1]), fz = std::floor(p[2]);
  const int x = static_cast<int>(fx), y = static_cast<int>(fy), z = static_cast<int>(fz);
  const double u = smooth(p[0] - fx), v = smooth(p[1] - fy), w = smooth(p[2] - fz);
  auto lerp = [](double a, double b, double t) { return a + (b - a) * t; };
  return lerp(
      lerp(lerp(cell(x, y, z), cell(x + 1, y, z), u), lerp(cell(x, y + 1, z), cell(x + 1, y + 1, z), u), v),
      lerp(lerp(cell(x, y, z + 1), cell(x + 1, y, z + 1), u),
           lerp(cell(x, y + 1, z + 1), cell(x + 1, y + 1, z + 1), u), v),
      w);
}
// Three octaves of it, 0..1 with mean 0.5.
double fbm3(const Vec3d& p) {
  return (4 * noise3(p) + 2 * noise3(p * 2.03 + Vec3d(17.1, 3.3, 9.7)) +
          noise3(p * 4.11 + Vec3d(5.2, 41.0, 1.7))) /
         7.0;
}
double frac(double x) {
  return x - std::floor(x);
}

// A primitive intersected by rays in the object frame.
class Shape {
 public:
  explicit Shape(int material) : material_(material) {}
  virtual ~Shape() = default;
  virtual bool intersect(const Vec3d& o, const Vec3d& d, Hit& hit) const = 0;

 protected:
  bool accept(double t, const Vec3d& n, Hit& hit, int material = -1) const {
    if (t <= 1e-6 || t >= hit.t) return false;
    hit.t = t;
    hit.n = n;
    hit.material = material >= 0 ? material : material_;
    return true;
  }
  int material_;
};

class Box : public Shape {
 public:
  Box(Vec3d lo, Vec3d hi, int m) : Shape(m), lo_(lo), hi_(hi) {}
  bool intersect(const Vec3d& o, const Vec3d& d, Hit& hit) const override {
    double t0 = -1e30, t1 = 1e30;
    int axis = -1;
    double sign = 0;
    for (int a = 0; a < 3; ++a) {
      if (std::abs(d[a]) < 1e-12) {
        if (o[a] < lo_[a] || o[a] > hi_[a]) return false;
        continue;
      }
      double ta = (lo_[a] - o[a]) / d[a], tb = (hi_[a] - o[a]) / d[a];
      double s = -1;  // entering through the low face
      if (ta > tb) {
        std::swap(ta, tb);
        s = 1;
      }
      if (ta > t0) {
        t0 = ta;
        axis = a;
        sign = s;
      }
      t1 = std::min(t1, tb);
      if (t0 > t1) return false;
    }
    if (axis < 0) return false;
    Vec3d n(0, 0, 0);
    n[axis] = sign;
    return accept(t0, n, hit);
  }

 private:
  Vec3d lo_, hi_;
};

// A capsule (a sphere when both ends coincide): all points within `r` of the segment a-b.
class Capsule : public Shape {
 public:
  Capsule(Vec3d a, Vec3d b, double r, int m) : Shape(m), a_(a), b_(b), r_(r) {}
  bool intersect(const Vec3d& o, const Vec3d& d, Hit& hit) const override {
    const Vec3d ba = b_ - a_, oa = o - a_;
    const double baba = ba.dot(ba), bard = ba.dot(d), baoa = ba.dot(oa), rdoa = d.dot(oa), oaoa = oa.dot(oa);
    double a = baba - bard * bard, b = baba * rdoa - baoa * bard,
           c = baba * oaoa - baoa * baoa - r_ * r_ * baba;
    double h = b * b - a * c;
    if (baba > 1e-12 && h >= 0.0 && a > 1e-12) {
      const double t = (-b - std::sqrt(h)) / a;
      const double y = baoa + t * bard;
      if (y > 0.0 && y < baba) {
        const Vec3d p = o + t * d;
        const Vec3d n = p - (a_ + ba * (y / baba));
        return accept(t, n / cv::norm(n), hit);
      }
    }
    // The end caps are spheres.
    bool any = false;
    for (const Vec3d& cen : {a_, b_}) {
      const Vec3d oc = o - cen;
      const double bb = oc.dot(d), cc = oc.dot(oc) - r_ * r_, hh = bb * bb - cc;
      if (hh < 0) continue;
      const double t = -bb - std::sqrt(hh);
      const Vec3d p = o + t * d;
      any |= accept(t, (p - cen) / r_, hit);
    }
    return any;
  }

 private:
  Vec3d a_, b_;
  double r_;
};

// A wheel: a cylinder around the y axis.
class Wheel : public Shape {
 public:
  // `zmin` clips the disc from below (wheel arches end at the sill).
  Wheel(Vec3d c, double r, double half_width, int m, double zmin = -1e9)
      : Shape(m), c_(c), r_(r), hw_(half_width), zmin_(zmin) {}
  bool intersect(const Vec3d& o, const Vec3d& d, Hit& hit) const override {
    bool any = false;
    const double ox = o[0] - c_[0], oz = o[2] - c_[2];
    const double a = d[0] * d[0] + d[2] * d[2];
    if (a > 1e-12) {
      const double b = ox * d[0] + oz * d[2], cc = ox * ox + oz * oz - r_ * r_;
      const double h = b * b - a * cc;
      if (h >= 0) {
        const double t = (-b - std::sqrt(h)) / a;
        const double y = o[1] + t * d[1] - c_[1];
        if (std::abs(y) <= hw_ && o[2] + t * d[2] >= zmin_)
          any |= accept(t, Vec3d((ox + t * d[0]) / r_, 0, (oz + t * d[2]) / r_), hit);
      }
    }
    if (std::abs(d[1]) > 1e-12)
      for (double s : {-1.0, 1.0}) {
        const double t = (c_[1] + s * hw_ - o[1]) / d[1];
        const double x = ox + t * d[0], z = oz + t * d[2];
        if (x * x + z * z <= r_ * r_ && z + c_[2] >= zmin_) any |= accept(t, Vec3d(0, s, 0), hit);
      }
    return any;
  }

 private:
  Vec3d c_;
  double r_, hw_, zmin_;
};

// A convex polyhedron: the points with n . p <= d for every plane; each face has its own material, so one
// body carries paint, glass and lamps.
struct Plane {
  Vec3d n;
  double d = 0;
  int material = -1;  // -1 = the body's material
};

class Convex : public Shape {
 public:
  Convex(std::vector<Plane> planes, int m) : Shape(m), planes_(std::move(planes)) {
    for (auto& p : planes_) {
      const double len = cv::norm(p.n);
      p.n /= len;
      p.d /= len;
    }
  }
  bool intersect(const Vec3d& o, const Vec3d& dir, Hit& hit) const override {
    double t0 = -1e30, t1 = 1e30;
    int enter = -1;
    for (size_t i = 0; i < planes_.size(); ++i) {
      const Plane& p = planes_[i];
      const double den = p.n.dot(dir), dist = p.d - p.n.dot(o);
      if (std::abs(den) < 1e-12) {
        if (dist < 0) return false;
        continue;
      }
      const double t = dist / den;
      if (den < 0) {
        if (t > t0) {
          t0 = t;
          enter = static_cast<int>(i);
        }
      } else {
        t1 = std::min(t1, t);
      }
      if (t0 > t1) return false;
    }
    if (enter < 0) return false;
    const Plane& e = planes_[static_cast<size_t>(enter)];
    return accept(t0, e.n, hit, e.material);
  }
  // The same body grown by `by` metres on every face (trim and lamps sit on top of the paint).
  std::vector<Plane> grown(double by) const {
    std::vector<Plane> g = planes_;
    for (auto& p : g) {
      p.d += by;
      p.material = -1;
    }
    return g;
  }

 private:
  std::vector<Plane> planes_;
};

struct Model {
  std::string object_class;
  std::string instance;
  std::string file_prefix;  // the pictures' file names start with it (the class when empty)
  Vec3d size_lwh;
  std::vector<Material> materials;
  std::vector<std::shared_ptr<const Shape>> shapes;    // shared: Model is copied into a vector
  std::vector<std::shared_ptr<const Shape>> interior;  // seen only through glass that transmits
  int target_height_px = 240;

  int material(Vec3d bgr, double spec = 0.0, double emissive = 0.0, Pattern pattern = Pattern::none,
               Vec3d centre = {}, double size = 0.0) {
    materials.push_back({bgr, spec, emissive, 0.0, pattern, centre, size});
    return static_cast<int>(materials.size()) - 1;
  }
  void box(Vec3d lo, Vec3d hi, int m) { shapes.push_back(std::make_shared<Box>(lo, hi, m)); }
  void capsule(Vec3d a, Vec3d b, double r, int m) { shapes.push_back(std::make_shared<Capsule>(a, b, r, m)); }
  void wheel(Vec3d c, double r, double hw, int m, double zmin = -1e9) {
    shapes.push_back(std::make_shared<Wheel>(c, r, hw, m, zmin));
  }
  const Convex& convex(std::vector<Plane> planes, int m) {
    auto c = std::make_shared<Convex>(std::move(planes), m);
    shapes.push_back(c);
    return *c;
  }
};

// Four wheels with lighter hubs; the tyres touch the ground and stay inside the box's width.
void add_wheels(Model& m, const std::vector<double>& xs, double r, double half_w, double tyre_w) {
  const int tyre = m.material({0.07, 0.07, 0.08}, 0.05, 0.0, Pattern::tread, {}, r);
  for (double x : xs) {
    const int hub = m.material({0.55, 0.55, 0.57}, 0.2, 0.0, Pattern::spokes, {x, 0, r}, r * 0.58);
    for (double s : {-1.0, 1.0}) {
      const double yc = s * (half_w - tyre_w / 2);
      m.wheel({x, yc, r}, r, tyre_w / 2, tyre);
      m.wheel({x, yc + s * 0.005, r}, r * 0.58, tyre_w / 2, hub);
    }
  }
}

// Lamps and plates on the front (s = +1) or rear (s = -1) face at x = s * x_face.
void add_lamps(Model& m, double s, double x_face, double y_in, double y_out, double z0, double z1, int lamp) {
  for (double side : {-1.0, 1.0}) {
    const double xa = s * x_face, xb = s * (x_face - 0.03);
    m.box({std::min(xa, xb), std::min(side * y_in, side * y_out), z0},
          {std::max(xa, xb), std::max(side * y_in, side * y_out), z1}, lamp);
  }
}

// A plane n . p <= d with n normalised (so offsets are in metres); `mat` -1 = the body's material.
Plane pl(Vec3d n, double d, int mat = -1) {
  const double len = cv::norm(n);
  return {n / len, d / len, mat};
}
// The slab of points within `w` metres inside plane `q` (for trim bands along a face).
Plane near(const Plane& q, double w) {
  return {-q.n, -(q.d - w), -1};
}
std::vector<Plane> operator+(std::vector<Plane> a, const std::vector<Plane>& b) {
  a.insert(a.end(), b.begin(), b.end());
  return a;
}

// A saloon car from convex pieces: a body with sloping hood and trunk and rounded corners, a glasshouse with
// raked windscreen and rear window and tumblehome sides, pillars, wrap-around lamps, bumpers, plates, arches,
// riding 0.20 m above the road (a saloon's clearance; at 0.28 m the dark band under the body read as a
// truck's chassis up close). The car comes in the commonest colours that YOLOv8n labels `car` as often as any
// (docs/augmentation.md, measured with hf_ar_renderer_detectability). Silver is the default instance (files
// car_*.png), the others car_<colour>_*.png; the renderer picks one per hazard.
struct Paint {
  const char* name;  // "" = the default instance
  Vec3d bgr;
  double specular;
};
const Paint kCarPaints[] = {
    {"", {0.55, 0.55, 0.57}, 0.5}, {"white", {0.85, 0.85, 0.86}, 0.4}, {"grey", {0.35, 0.35, 0.36}, 0.5}};

Model make_car(const Paint& colour) {
  Model m;
  m.object_class = "car";
  m.instance = std::string("car_") + (*colour.name ? colour.name : "default");
  m.file_prefix = std::string("car") + (*colour.name ? std::string("_") + colour.name : "");
  m.size_lwh = {4.50, 1.85, 1.52};
  const int paint = m.material(colour.bgr, colour.specular, 0.0, Pattern::paint);
  const int glass = m.material({0.06, 0.06, 0.06}, 0.7);
  m.materials[static_cast<size_t>(glass)].transmits = 0.8;
  const int trim = m.material({0.10, 0.10, 0.11}, 0.08);
  const int tail = m.material({0.12, 0.10, 0.85}, 0.3, 0.45, Pattern::lamp);
  const int head = m.material({0.82, 0.92, 0.95}, 0.4, 0.45, Pattern::lamp);
  const int plate = m.material({0.92, 0.92, 0.92}, 0.05, 0.0, Pattern::plate, {-2.2, 0, 0.60}, 0.075);
  const int front_plate = m.material({0.92, 0.92, 0.92}, 0.05, 0.0, Pattern::plate, {2.2, 0, 0.385}, 0.07);
  const int arch = m.material({0.03, 0.03, 0.03}, 0.0);
  const int seat = m.material({0.16, 0.16, 0.17}, 0.05, 0.0, Pattern::seat);
  const int dash = m.material({0.09, 0.09, 0.10}, 0.1);

  const double side = 0.915;
  const std::vector<Plane> body_planes = {
      pl({0, 0, -1}, -0.20),  // underside
      pl({0, 1, 0}, side),
      pl({0, -1, 0}, side),  // flanks
      pl({1, 0, 0}, 2.25),
      pl({-1, 0, 0}, 2.25),  // nose, tail
      pl({0, 0, 1}, 0.98),   // belt line
      pl({0.16, 0, 1}, 1.14),
      pl({-0.1067, 0, 1}, 1.14),  // hood and trunk lid slope down
      pl({1, 1, 0}, 2.95),
      pl({1, -1, 0}, 2.95),  // rounded front corners
      pl({-1, 1, 0}, 2.97),
      pl({-1, -1, 0}, 2.97),  // rounded rear corners
      pl({0, 0.6, 0.8}, 0.6 * side + 0.8 * 0.90),
      pl({0, -0.6, 0.8}, 0.6 * side + 0.8 * 0.90),  // shoulders
      pl({0, 0.6, -0.8}, 0.6 * side - 0.8 * 0.28),
      pl({0, -0.6, -0.8}, 0.6 * side - 0.8 * 0.28),  // sills
      pl({0.6, 0, 0.8}, 0.6 * 2.25 + 0.8 * 0.72),    // nose top edge
      pl({-0.6, 0, 0.8}, 0.6 * 2.25 + 0.8 * 0.84),   // tail top edge
  };
  const Convex& body = m.convex(body_planes, paint);

  // Windscreen from (x 1.15, z 0.97) to (0.30, 1.50); rear window from (-1.45, 0.98) to (-0.85, 1.50),
  // leaving a trunk deck; side glass leaning in from |y| 0.86 at the belt to 0.62 at the roof.
  const Plane windscreen = pl({0.624, 0, 1}, 1.6876, glass), rear_window = pl({-0.867, 0, 1}, 2.237, glass);
  const Plane left = pl({0, 1, 0.436}, 1.274, glass), right = pl({0, -1, 0.436}, 1.274, glass);
  const std::vector<Plane> cabin_planes = {
      pl({0, 0, -1}, -0.95), pl({0, 0, 1}, 1.52, paint), windscreen, rear_window, left, right};
  const Convex& cabin = m.convex(cabin_planes, glass);
  const auto shell = cabin.grown(0.012);
  for (const Plane& s : {left, right}) {
    m.convex(shell + std::vector<Plane>{near(windscreen, 0.10), near(s, 0.10)}, paint);   // A pillars
    m.convex(shell + std::vector<Plane>{near(rear_window, 0.12), near(s, 0.18)}, paint);  // C pillars
    m.convex(shell + std::vector<Plane>{near(s, 0.05), pl({0, 0, -1}, -1.45)}, paint);    // roof rails
  }
  m.convex(shell + std::vector<Plane>{pl({1, 0, 0}, -0.36), pl({-1, 0, 0}, 0.46)}, paint);  // B pillars

  auto band = [&](double grow, std::vector<Plane> limits, int mat) {
    m.convex(body.grown(grow) + limits, mat);
  };
  band(0.010, {pl({-1, 0, 0}, 1.95), pl({0, 0, 1}, 0.40)}, trim);                          // front bumper
  band(0.010, {pl({1, 0, 0}, -1.95), pl({0, 0, 1}, 0.40)}, trim);                          // rear bumper
  band(0.005, {pl({0, 0, 1}, 0.28)}, trim);                                                // sills
  band(0.004, {pl({1, 0, 0}, -2.05), pl({0, 0, -1}, -0.875), pl({0, 0, 1}, 0.89)}, trim);  // trunk lid gap
  for (double sy : {1.0, -1.0}) {
    band(0.014, {pl({1, 0, 0}, -2.02), pl({0, 0, -1}, -0.70), pl({0, 0, 1}, 0.86), pl({0, -sy, 0}, -0.45)},
         tail);
    band(0.014, {pl({-1, 0, 0}, -2.00), pl({0, 0, -1}, -0.62), pl({0, 0, 1}, 0.74), pl({0, -sy, 0}, -0.47)},
         head);
  }
  band(0.012,
       {pl({-1, 0, 0}, -2.15), pl({0, 0, -1}, -0.50), pl({0, 0, 1}, 0.61), pl({0, 1, 0}, 0.40),
        pl({0, -1, 0}, 0.40)},
       trim);  // grille
  band(0.018,
       {pl({1, 0, 0}, -2.20), pl({0, 0, -1}, -0.54), pl({0, 0, 1}, 0.66), pl({0, 1, 0}, 0.26),
        pl({0, -1, 0}, 0.26)},
       plate);
  band(0.022,
       {pl({-1, 0, 0}, -2.20), pl({0, 0, -1}, -0.33), pl({0, 0, 1}, 0.44), pl({0, 1, 0}, 0.26),
        pl({0, -1, 0}, 0.26)},
       front_plate);
  for (double x : {0.79, -0.42})  // door shut lines
    band(0.003, {pl({1, 0, 0}, x + 0.012), pl({-1, 0, 0}, -(x - 0.012)), pl({0, 0, -1}, -0.37)}, trim);
  for (double x : {1.42, -1.38}) m.wheel({x, 0, 0.33}, 0.41, 0.920, arch, 0.20);  // arches
  add_wheels(m, {1.42, -1.38}, 0.33, 0.925, 0.22);
  // The cabin seen through the glass: front and rear seat backs with head rests, the dashboard.
  auto inside_box = [&](Vec3d lo, Vec3d hi, int mat) {
    m.interior.push_back(std::make_shared<Box>(lo, hi, mat));
  };
  auto inside_capsule = [&](Vec3d a, Vec3d b, double r, int mat) {
    m.interior.push_back(std::make_shared<Capsule>(a, b, r, mat));
  };
  for (double y : {-0.40, 0.40}) {
    inside_box({-0.25, y - 0.26, 0.45}, {-0.12, y + 0.26, 1.12}, seat);
    inside_capsule({-0.20, y - 0.08, 1.24}, {-0.20, y + 0.08, 1.24}, 0.085, seat);
  }
  inside_box({-1.20, -0.72, 0.45}, {-1.05, 0.72, 1.05}, seat);
  for (double y : {-0.45, 0.0, 0.45})
    inside_capsule({-1.14, y - 0.07, 1.14}, {-1.14, y + 0.07, 1.14}, 0.075, seat);
  inside_box({0.75, -0.80, 0.80}, {1.20, 0.80, 1.02}, dash);
  inside_box({-1.50, -0.86, 0.40}, {1.20, 0.86, 0.46}, dash);  // the floor and parcel shelf level
  return m;
}

Model make_truck() {
  Model m;
  m.object_class = "truck";
  m.instance = "truck_default";
  m.size_lwh = {8.00, 2.50, 3.00};
  const double hl = 4.0, hw = 1.25;
  const int cab = m.material({0.92, 0.92, 0.90}, 0.2);
  const int cargo = m.material({0.78, 0.80, 0.80}, 0.05);
  const int glass = m.material({0.18, 0.14, 0.12}, 0.5);
  const int chassis = m.material({0.12, 0.12, 0.12}, 0.05);
  const int tail = m.material({0.10, 0.08, 0.80}, 0.2, 0.45);
  const int head = m.material({0.80, 0.92, 0.95}, 0.3, 0.45);
  add_wheels(m, {2.9, -1.9, -3.1}, 0.50, hw - 0.02, 0.34);
  m.box({-3.95, -1.10, 0.45}, {3.95, 1.10, 1.00}, chassis);  // chassis
  m.box({-hl, -hw, 0.95}, {1.85, hw, 3.00}, cargo);          // cargo box
  m.box({2.00, -1.20, 0.55}, {3.95, 1.20, 2.70}, cab);       // cab
  m.box({3.30, -1.12, 1.75}, {3.97, 1.12, 2.55}, glass);     // windscreen + side windows
  m.box({3.90, -1.15, 0.40}, {hl, 1.15, 0.75}, chassis);     // front bumper
  add_lamps(m, 1, hl - 0.005, 0.75, 1.10, 0.85, 1.00, head);
  add_lamps(m, -1, hl - 0.005, 0.80, 1.15, 0.55, 0.80, tail);
  m.box({-hl, -1.22, 0.45}, {-3.96, 1.22, 0.55}, chassis);  // rear underrun bar
  return m;
}

Model make_bus() {
  Model m;
  m.object_class = "bus";
  m.instance = "bus_default";
  m.size_lwh = {11.0, 2.55, 3.20};
  const double hl = 5.5, hw = 1.275;
  const int paint = m.material({0.20, 0.62, 0.90}, 0.2);  // yellow-orange
  const int glass = m.material({0.18, 0.14, 0.12}, 0.5);
  const int trim = m.material({0.12, 0.12, 0.12}, 0.05);
  const int tail = m.material({0.10, 0.08, 0.80}, 0.2, 0.45);
  const int head = m.material({0.80, 0.92, 0.95}, 0.3, 0.45);
  add_wheels(m, {3.9, -3.0}, 0.50, hw - 0.01, 0.32);
  m.box({-hl + 0.02, -1.25, 0.30}, {hl - 0.02, 1.25, 3.20}, paint);
  m.box({-hl + 0.40, -1.265, 1.35}, {hl - 0.40, 1.265, 2.65}, glass);  // side window band
  m.box({hl - 0.03, -1.10, 1.00}, {hl, 1.10, 2.85}, glass);            // windscreen
  m.box({-hl, -1.00, 2.00}, {-hl + 0.03, 1.00, 2.80}, glass);          // rear window
  m.box({hl - 0.05, -1.26, 0.25}, {hl, 1.26, 0.55}, trim);             // bumpers
  m.box({-hl, -1.26, 0.25}, {-hl + 0.05, 1.26, 0.55}, trim);
  add_lamps(m, 1, hl - 0.005, 0.85, 1.15, 0.65, 0.85, head);
  add_lamps(m, -1, hl - 0.005, 0.90, 1.20, 0.70, 1.10, tail);
  return m;
}

// A pedestrian from capsules: legs mid-stride (thigh and shin), pelvis, a torso wider than deep, shoulders,
// arms swinging against the legs, hands, neck, head with hair.
Model make_person() {
  Model m;
  m.object_class = "person";
  m.instance = "person_default";
  m.size_lwh = {0.50, 0.60, 1.70};
  m.target_height_px = 320;
  const Vec3d head_centre(0.005, 0, 1.585);
  const int skin = m.material({0.50, 0.60, 0.78}, 0.05, 0.0, Pattern::face, head_centre, 0.105);
  const int hair = m.material({0.07, 0.08, 0.11}, 0.1, 0.0, Pattern::hair, head_centre, 0.105);
  const int jacket = m.material({0.20, 0.22, 0.52}, 0.08, 0.0, Pattern::fabric);  // dark red jacket
  const int jeans = m.material({0.42, 0.27, 0.17}, 0.05, 0.0, Pattern::denim);
  const int shoes = m.material({0.09, 0.09, 0.10}, 0.1);
  for (double s : {1.0, -1.0}) {
    const double stride = 0.15 * s;  // left leg forward, right leg back
    const Vec3d hip(0.0, 0.105 * s, 0.90), knee(0.55 * stride, 0.11 * s, 0.49),
        ankle(stride, 0.115 * s, 0.10);
    m.capsule(hip, knee, 0.083, jeans);
    m.capsule(knee, ankle, 0.062, jeans);
    m.capsule(ankle + Vec3d(-0.03, 0, -0.05), ankle + Vec3d(0.05, 0, -0.05), 0.048, shoes);
    // Arms swing opposite to the legs.
    const Vec3d shoulder(0.0, 0.205 * s, 1.37), elbow(-0.35 * stride, 0.235 * s, 1.10),
        wrist(-0.75 * stride, 0.245 * s, 0.88);
    m.capsule(shoulder, elbow, 0.052, jacket);
    m.capsule(elbow, wrist, 0.044, jacket);
    m.capsule(wrist + Vec3d(0, 0, -0.04), wrist + Vec3d(0, 0, -0.04), 0.045, skin);
  }
  m.capsule({0, -0.10, 0.93}, {0, 0.10, 0.93}, 0.11, jeans);       // pelvis
  m.capsule({0, -0.085, 1.00}, {0, -0.085, 1.30}, 0.125, jacket);  // torso: two columns, wider than deep
  m.capsule({0, 0.085, 1.00}, {0, 0.085, 1.30}, 0.125, jacket);
  m.capsule({0, -0.15, 1.36}, {0, 0.15, 1.36}, 0.075, jacket);     // shoulders
  m.capsule({0, 0, 1.40}, {0, 0, 1.50}, 0.05, skin);               // neck
  m.capsule(head_centre, head_centre, 0.105, skin);                // head
  m.capsule({-0.012, 0, 1.595}, {-0.012, 0, 1.595}, 0.105, hair);  // hair, set back from the face
  return m;
}

struct Camera {
  Vec3d pos, x, y, z;  // optical axes in the object frame
  double f = 1, cx = 0, cy = 0;
  cv::Point2d project(const Vec3d& p) const {
    const Vec3d d = p - pos;
    return {f * d.dot(x) / d.dot(z) + cx, f * d.dot(y) / d.dot(z) + cy};
  }
};

// A dash-camera-like viewpoint: 1.6 m above the ground, far enough for mild perspective.
Camera view_camera(const Model& m, double azimuth_deg, cv::Size& size) {
  const double az = azimuth_deg * CV_PI / 180.0;
  // Vehicles seen from 8 m (1.8 lengths for trucks and buses): hazards are shown at 8-40 m, and a picture
  // rendered from farther and warped onto a near box keeps a far view's flat perspective; YOLOv8n found the
  // default car in 55 of 64 insertions rendered from 15 m, 63 of 64 from 8.1 m
  // (hf_ar_renderer_detectability). A person is too thin for the perspective to matter and stays at 15 m
  // (from 8 m: found as often, but YOLOX's boxes fitted it worse, mean IoU 0.73 against 0.82 in the nuScenes
  // pedestrian configs).
  const double dist = m.object_class == "person" ? 15.0 : std::max(8.0, 1.8 * m.size_lwh[0]);
  Camera c;
  c.pos = Vec3d(dist * std::cos(az), dist * std::sin(az), 1.6);
  const Vec3d target(0, 0, m.size_lwh[2] / 2);
  c.z = (target - c.pos) / cv::norm(target - c.pos);
  c.x = c.z.cross(Vec3d(0, 0, 1));
  c.x /= cv::norm(c.x);
  c.y = c.z.cross(c.x);
  const auto corners = hr::box_corners(0, 0, 0, m.size_lwh);
  double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
  for (const auto& p : corners) {
    const cv::Point2d q = c.project(p);
    x0 = std::min(x0, q.x);
    x1 = std::max(x1, q.x);
    y0 = std::min(y0, q.y);
    y1 = std::max(y1, q.y);
  }
  const double margin = 3;
  c.f = m.target_height_px / (y1 - y0);
  c.cx = -x0 * c.f + margin;
  c.cy = -y0 * c.f + margin;
  size = cv::Size(static_cast<int>(std::ceil((x1 - x0) * c.f + 2 * margin)),
                  static_cast<int>(std::ceil((y1 - y0) * c.f + 2 * margin)));
  return c;
}

// The surroundings that paint and glass mirror: a sky with clouds, a skyline of buildings (rows of windows)
// and trees along the horizon, the road below. Reflections of it are the sharpest detail on a real car.
Vec3d environment(const Vec3d& r) {
  const double el = std::asin(std::clamp(r[2], -1.0, 1.0));
  const double az = std::atan2(r[1], r[0]) + CV_PI;  // 0..2 pi
  if (el < 0) return Vec3d(0.24, 0.24, 0.25) * (0.85 + 0.3 * fbm3(Vec3d(az * 20, el * 40, 0.5)));
  const int seg = static_cast<int>(std::floor(az / 0.13));
  const bool tree = cell(seg, 3, 2) < 0.4;
  const double top = tree ? 0.05 + 0.08 * cell(seg, 5) + 0.05 * (fbm3(Vec3d(az * 30, 0.5, 2.5)) - 0.5)
                          : 0.04 + 0.16 * cell(seg, 7);
  if (el < top) {
    if (tree) return Vec3d(0.20, 0.27, 0.24) * (0.6 + 0.8 * fbm3(Vec3d(az * 60, el * 60, 7.5)));
    const double wall = 0.30 + 0.30 * cell(seg, 11);
    const bool window = frac(az / 0.021) > 0.3 && frac(az / 0.021) < 0.8 && frac(el / 0.025) > 0.35 &&
                        frac(el / 0.025) < 0.85 && el < top - 0.01;
    return Vec3d(wall, wall, wall * 1.04) * (window ? 0.45 : 1.0);
  }
  const double clouds = fbm3(Vec3d(az * 3, el * 9, 3.5));
  return Vec3d(0.95, 0.90, 0.85) * (0.80 + 0.20 * std::sin(el)) * (0.85 + 0.3 * clouds);
}

// The pattern's effect on the albedo at point p (object frame) with normal n: a factor per channel, or a
// replacement colour where the pattern draws something of its own (characters, seams).
Vec3d detail(const Material& mat, const Vec3d& p, const Vec3d& n, Vec3d albedo) {
  switch (mat.pattern) {
    case Pattern::none:
      return albedo;
    case Pattern::paint: {
      const double grime = std::clamp((0.45 - p[2]) / 0.3, 0.0, 1.0);
      const double dirt = fbm3(p * 30.0);
      return albedo * (1.0 - 0.25 * grime * (0.6 + 0.8 * dirt));
    }
    case Pattern::plate: {
      // Seven characters from a 3x5 grid of strokes, picked per character; 0.75 of the height tall.
      const double ch = mat.size, cw = 0.6 * ch, gap = 0.25 * ch;
      const double u = (p[1] - mat.centre[1]) * (mat.centre[0] < 0 ? -1 : 1) + 3.5 * (cw + gap);
      const double v = (mat.centre[2] + ch / 2) - p[2];
      if (v < 0 || v > ch || u < 0) return albedo;
      const int k = static_cast<int>(std::floor(u / (cw + gap)));
      const double cu = u - k * (cw + gap);
      if (k >= 7 || cu > cw) return albedo;
      const int gx = std::min(2, static_cast<int>(cu / cw * 3)),
                gy = std::min(4, static_cast<int>(v / ch * 5));
      const bool stroke =
          (gx != 1 && cell(k, gy, gx) < 0.75) || (gx == 1 && gy % 2 == 0 && cell(k, gy, 9) < 0.7);
      return stroke ? Vec3d(0.06, 0.06, 0.07) : albedo;
    }
    case Pattern::lamp: {
      // Ribs across the lens and a brighter reflector in its inner part.
      const double rib = frac(p[2] / 0.028) < 0.5 ? 1.0 : 0.72;
      const double inner = std::abs(p[1]) > 0.62 ? 1.25 : 1.0;
      return albedo * rib * inner;
    }
    case Pattern::tread:
      // Grooves around the circumference on the running face; the sidewall's moulding as faint texture.
      if (std::abs(n[1]) > 0.5) return albedo * (0.85 + 0.3 * fbm3(p * 60.0));
      return albedo * (frac(p[1] / 0.035) < 0.3 ? 0.45 : 1.0);
    case Pattern::spokes: {
      const double dx = p[0] - mat.centre[0], dz = p[2] - mat.centre[2];
      const double rad = std::hypot(dx, dz) / mat.size;
      if (rad < 0.22) return albedo * 1.1;  // centre cap
      if (rad > 0.86) return albedo * 0.8;  // rim
      const double ang = std::atan2(dz, dx) / (2 * CV_PI) * 5.0;
      return frac(ang) < 0.55 ? Vec3d(0.05, 0.05, 0.05) : albedo;  // gaps between five spokes show the brake
    }
    case Pattern::fabric: {
      const double folds = fbm3(Vec3d(p[0] * 18, p[1] * 18, p[2] * 9));
      Vec3d c = albedo * (0.75 + 0.5 * folds);
      if (n[0] > 0.3 && std::abs(p[1]) < 0.008 && p[2] > 1.0 && p[2] < 1.40)
        c = Vec3d(0.08, 0.08, 0.09);               // zip
      if (std::abs(p[2] - 1.02) < 0.01) c *= 0.6;  // hem
      return c;
    }
    case Pattern::denim: {
      Vec3d c = albedo * (0.8 + 0.4 * fbm3(Vec3d(p[0] * 25, p[1] * 25, p[2] * 6)));
      if (std::abs(std::abs(p[1]) - 0.19) < 0.012 && std::abs(n[1]) > 0.6) c *= 1.3;  // outer seam
      if (std::abs(p[2] - 0.49) < 0.03) c *= 0.8;                                     // knee creases
      return c;
    }
    case Pattern::hair: {
      const Vec3d d = p - mat.centre;
      const double strands = frac(std::atan2(d[1], -d[0]) * 14.0 + 3.0 * d[2]);
      return albedo * (strands < 0.5 ? 0.7 : 1.4);
    }
    case Pattern::face: {
      const Vec3d d = p - mat.centre;
      if (cv::norm(d) > 1.3 * mat.size || d[0] < 0.03) return albedo;  // hands, the back of the head
      const double s = mat.size;
      for (double side : {-1.0, 1.0}) {
        if (std::hypot(d[1] - side * 0.35 * s, d[2] - 0.12 * s) < 0.11 * s)
          return Vec3d(0.10, 0.10, 0.12);  // eyes
        if (std::abs(d[2] - 0.30 * s) < 0.05 * s && std::abs(d[1] - side * 0.35 * s) < 0.2 * s)
          return albedo * 0.35;  // brows
      }
      if (std::abs(d[2] + 0.42 * s) < 0.05 * s && std::abs(d[1]) < 0.25 * s) return albedo * 0.55;  // mouth
      if (std::abs(d[1]) < 0.06 * s && d[2] < 0.05 * s && d[2] > -0.25 * s)
        return albedo * 1.12;  // nose ridge
      return albedo;
    }
    case Pattern::seat:
      return albedo * (frac(p[2] / 0.09) < 0.15 ? 0.6 : 1.0);
  }
  return albedo;
}

// Sky light from above, a fill light from the viewer's side and a key light from the front-left, so every
// visible face is readable; glass and paint reflect the surroundings.
Vec3d shade(const Model& m, const Hit& h, const Vec3d& ray, const Vec3d& p, const Vec3d& transmitted) {
  const Material& mat = m.materials[static_cast<size_t>(h.material)];
  Vec3d n = h.n;
  if (n.dot(ray) > 0) n = -n;
  static const Vec3d key = Vec3d(0.45, 0.35, 0.82) / cv::norm(Vec3d(0.45, 0.35, 0.82));
  const double sky = 0.5 + 0.5 * n[2];
  const double fill = std::max(0.0, -n.dot(ray));
  const double lambert = std::max(0.0, n.dot(key));
  // Ambient occlusion by height: surfaces near the ground see less sky.
  const double ao = 0.65 + 0.35 * std::clamp(p[2] / 0.9, 0.0, 1.0);
  const double light = ao * (0.22 + 0.30 * sky + 0.25 * fill + 0.35 * lambert);
  Vec3d col = detail(mat, p, n, mat.albedo) * (light * (1 - mat.emissive) + mat.emissive);
  // Glass lets the cabin behind it show through.
  if (mat.transmits > 0) col = col * (1 - mat.transmits) + transmitted * mat.transmits;
  // The surroundings mirrored in paint and glass, stronger at grazing angles (Schlick's Fresnel term). The
  // skyline across a car's flanks and windows is what makes real paint read as paint.
  const Vec3d refl = ray - 2 * ray.dot(n) * n;
  const double fresnel = 0.25 + 0.75 * std::pow(1.0 - std::max(0.0, -n.dot(ray)), 5.0);
  const double k = std::clamp(mat.specular * fresnel, 0.0, 1.0);
  if (k > 0) col = col * (1.0 - k) + environment(refl) * k;
  for (int c = 0; c < 3; ++c) col[c] = std::clamp(col[c], 0.0, 1.0);
  return col;
}

// The colour a ray through glass at point p meets inside the cabin: its seats and dashboard in the cabin's
// shade, or the dark far side.
Vec3d cabin(const Model& m, const Vec3d& p, const Vec3d& d) {
  Hit hit;
  for (const auto& s : m.interior) s->intersect(p, d, hit);
  if (hit.material < 0) return Vec3d(0.03, 0.03, 0.03);
  const Vec3d q = p + hit.t * d;
  const Material& mat = m.materials[static_cast<size_t>(hit.material)];
  Vec3d n = hit.n;
  if (n.dot(d) > 0) n = -n;
  const double light = 0.15 + 0.35 * std::max(0.0, n[2]) + 0.25 * std::max(0.0, -n.dot(d));
  return detail(mat, q, n, mat.albedo) * light;
}

cv::Mat render(const Model& m, const Camera& cam, cv::Size size) {
  constexpr int kSuper = 3;  // supersampling per axis, for anti-aliased edges and alpha
  cv::Mat acc(size, CV_64FC4, cv::Scalar::all(0));
  // Rows in parallel: every pixel is its own, so the picture does not depend on the number of threads.
  cv::parallel_for_(cv::Range(0, size.height), [&](const cv::Range& rows) {
    for (int y = rows.start; y < rows.end; ++y)
      for (int x = 0; x < size.width; ++x) {
        cv::Vec4d sum(0, 0, 0, 0);
        for (int sy = 0; sy < kSuper; ++sy)
          for (int sx = 0; sx < kSuper; ++sx) {
            const double u = (x + (sx + 0.5) / kSuper - cam.cx) / cam.f;
            const double v = (y + (sy + 0.5) / kSuper - cam.cy) / cam.f;
            Vec3d d = cam.z + u * cam.x + v * cam.y;
            d /= cv::norm(d);
            Hit hit;
            for (const auto& s : m.shapes) s->intersect(cam.pos, d, hit);
            if (hit.material < 0) continue;
            const Vec3d p = cam.pos + hit.t * d;
            const bool glass = m.materials[static_cast<size_t>(hit.material)].transmits > 0;
            const Vec3d c = shade(m, hit, d, p, glass ? cabin(m, p + 1e-4 * d, d) : Vec3d());
            sum += cv::Vec4d(c[0], c[1], c[2], 1.0);
          }
        acc.at<cv::Vec4d>(y, x) = sum / double(kSuper * kSuper);
      }
  });
  cv::Mat out(size, CV_8UC4);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      const cv::Vec4d a = acc.at<cv::Vec4d>(y, x);
      cv::Vec4b& o = out.at<cv::Vec4b>(y, x);
      for (int k = 0; k < 3; ++k) o[k] = cv::saturate_cast<uint8_t>(a[3] > 0 ? 255.0 * a[k] / a[3] : 0.0);
      o[3] = cv::saturate_cast<uint8_t>(255.0 * a[3]);
    }
  return out;
}

int run(const fs::path& out_dir, int vehicle_height, const std::string& only) {
  std::vector<Model> models;
  std::vector<Model> all;
  for (const Paint& p : kCarPaints) all.push_back(make_car(p));
  for (Model m : {make_truck(), make_bus(), make_person()}) all.push_back(std::move(m));
  // With --only, the folder's other classes stay listed, in the set's order: the index is the whole set's.
  std::vector<std::string> class_order;
  for (const Model& m : all)
    if (std::find(class_order.begin(), class_order.end(), m.object_class) == class_order.end())
      class_order.push_back(m.object_class);
  for (Model& m : all)
    if (only.empty() || m.object_class == only) models.push_back(std::move(m));
  if (models.empty()) throw hf::Error("--only '" + only + "' is not one of car, truck, bus, person");
  std::vector<hr::AssetSpec> kept;
  if (!only.empty() && fs::exists(out_dir / "assets.yaml"))
    for (const hr::AssetSpec& s : hr::load_asset_index(out_dir).assets)
      if (s.object_class != only) kept.push_back(s);
  hr::AssetIndex index;
  for (Model& m : models) {
    if (m.object_class != "person") m.target_height_px = vehicle_height;
    // Sixteen viewpoints, 22.5 degrees apart, so the renderer's nearest picture is never more than 11.25
    // degrees off: the eight named views plus one between each pair.
    for (int k = 0; k < 16; ++k) {
      const double az = hf::wrap_deg(22.5 * k);
      // In-between viewpoints take the name of their three-quarter neighbour (odd view index), symmetrically.
      const int bin = k % 2 ? ((k / 2) % 2 ? k / 2 : (k / 2 + 1) % 8) : k / 2;
      const std::string view = hr::view_names()[static_cast<size_t>(bin)];
      cv::Size size;
      const Camera cam = view_camera(m, az, size);
      const cv::Mat img = render(m, cam, size);
      hr::AssetSpec s;
      char az_tag[16];
      std::snprintf(az_tag, sizeof az_tag, "_az%03ld", std::lround(std::fmod(22.5 * k, 360.0)));
      s.file = (m.file_prefix.empty() ? m.object_class : m.file_prefix) + "_" + view + (k % 2 ? az_tag : "") +
               ".png";
      s.object_class = m.object_class;
      s.view = view;
      s.azimuth_deg = az;
      s.size_lwh = m.size_lwh;
      s.image_size = size;
      s.anchor_px = cam.project(Vec3d(0, 0, 0));
      const auto corners = hr::box_corners(0, 0, 0, m.size_lwh);
      for (int k = 0; k < 8; ++k) s.box_corners_px[k] = cam.project(corners[k]);
      s.source = "generated";
      s.instance = m.instance;
      s.origin = "hf_make_assets";
      hr::write_png_atomic(out_dir / s.file, img);
      index.assets.push_back(s);
      std::cout << "wrote " << (out_dir / s.file).string() << " (" << size.width << "x" << size.height
                << ")\n";
    }
  }
  hr::AssetIndex whole;
  for (const std::string& cls : class_order)
    for (const auto* list : {&index.assets, &kept})
      for (const hr::AssetSpec& s : *list)
        if (s.object_class == cls) whole.assets.push_back(s);
  hr::save_asset_index(
      out_dir, whole,
      "HazardForge default appearance assets, generated by hf_make_assets (tools/make_assets).\n"
      "Regenerate with: ninja -C <build> hf_regenerate_assets");
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  fs::path out;
  int height = 240;
  std::string only;
  const char* usage = "usage: hf_make_assets --out DIR [--height PX (>= 32)] [--only car|truck|bus|person]\n";
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--out" && i + 1 < argc) {
      out = argv[++i];
    } else if (a == "--height" && i + 1 < argc) {
      height = std::atoi(argv[++i]);
    } else if (a == "--only" && i + 1 < argc) {
      only = argv[++i];
    } else {
      std::cerr << usage;
      return 2;
    }
  }
  if (out.empty() || height < 32) {
    std::cerr << usage;
    return 2;
  }
  try {
    return run(out, height, only);
  } catch (const std::exception& e) {
    std::cerr << "hf_make_assets: " << e.what() << "\n";
    return 1;
  }
}
