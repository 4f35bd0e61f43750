// A Ceres Solver peer of `lincal calibrate --refine`, written the way ROS robot_calibration /
// robot_cal_tools users write a kinematic calibration: one ceres::AutoDiffCostFunction per pose,
// residual = predicted tip - measured tip (or - the unknown point it is pinned at), the tool
// point carried back through the DH chain with one sin/cos pair per angle, Levenberg-Marquardt
// with DENSE_NORMAL_CHOLESKY and the default tolerances, starting from the nominals.
//
//   peer_ceres PROBLEM.txt DATA.csv OUT.json [--threads K] [--verbose] [--tolerance TOL]
//
// --threads K: Solver::Options::num_threads (default 1). --tolerance TOL: function and
// parameter tolerance TOL, gradient tolerance TOL * 1e-4, up to 500 iterations, instead of
// Ceres' defaults (1e-6, 1e-8, 1e-10, 50): a convergence check, not what the bench times.
//
// PROBLEM.txt is written (untimed) by bench/ceres/prepare.py from a lincal spec and
// `lincal basis SPEC --format json` (the parameters lincal holds are fixed here too, as are
// the spec's known ones). DATA.csv is what `lincal simulate` writes (header q1..qn,x,y,z or
// q1..qn,constraint; lines starting with # are comments). OUT.json: {name: value} for every
// parameter of the spec, in spec order, the form bench/peer_lm.py writes.
//
// Parameter blocks: "dh" (4 per joint: a, alpha, d, home for a revolute joint; a, alpha,
// theta, offset for a prismatic one), "tool" (3), "base" (6: x y z roll pitch yaw, only when
// the spec has a base) and, for point constraints, one block of 3 per point. A slot holding a
// constant, a known or a held parameter is fixed with a ceres::SubsetManifold.
#include <ceres/ceres.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

namespace {

[[noreturn]] void die(const std::string& msg) {
  std::fprintf(stderr, "peer_ceres: %s\n", msg.c_str());
  std::exit(1);
}

// ---- the problem file -----------------------------------------------------------------------
struct Slot {          // one number of a parameter block: a parameter's or a constant
  std::string name;    // empty: constant
  double value = 0;
};

struct Problem {
  bool mdh = true;
  bool point_kind = false;
  std::vector<std::string> names;            // every spec parameter, spec order
  std::map<std::string, double> nominal;
  std::map<std::string, std::string> flag;   // free | known | held
  std::vector<bool> prismatic;
  std::vector<Slot> dh;                      // 4 per joint
  std::vector<Slot> tool;                    // 3
  std::vector<Slot> base;                    // 6 or none
  std::vector<std::vector<Slot>> points;     // 3 each
};

Slot parse_slot(const std::string& tok, const Problem& p) {
  Slot s;
  if (!tok.empty() && tok[0] == '=') {
    s.value = std::strtod(tok.c_str() + 1, nullptr);
  } else {
    auto it = p.nominal.find(tok);
    if (it == p.nominal.end()) die("problem file: unknown parameter " + tok);
    s.name = tok;
    s.value = it->second;
  }
  return s;
}

Problem read_problem(const char* path) {
  std::ifstream in(path);
  if (!in) die(std::string("cannot read ") + path);
  Problem p;
  std::string line;
  auto slots = [&](std::istringstream& ss, int n, std::vector<Slot>& out) {
    for (int k = 0; k < n; ++k) {
      std::string t;
      if (!(ss >> t)) die("problem file: short line: " + line);
      out.push_back(parse_slot(t, p));
    }
  };
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream ss(line);
    std::string key;
    ss >> key;
    if (key == "convention") {
      std::string c;
      ss >> c;
      if (c != "mdh" && c != "dh") die("problem file: convention " + c);
      p.mdh = c == "mdh";
    } else if (key == "kind") {
      std::string k;
      ss >> k;
      if (k != "measured" && k != "point") die("problem file: kind " + k);
      p.point_kind = k == "point";
    } else if (key == "param") {
      std::string n, v, f;
      ss >> n >> v >> f;
      if (f != "free" && f != "known" && f != "held") die("problem file: flag " + f);
      p.names.push_back(n);
      p.nominal[n] = std::strtod(v.c_str(), nullptr);
      p.flag[n] = f;
    } else if (key == "joint") {
      std::string type;
      ss >> type;
      if (type != "revolute" && type != "prismatic") die("problem file: joint type " + type);
      p.prismatic.push_back(type == "prismatic");
      slots(ss, 4, p.dh);
    } else if (key == "tool") {
      slots(ss, 3, p.tool);
    } else if (key == "base") {
      slots(ss, 6, p.base);
    } else if (key == "point") {
      p.points.emplace_back();
      slots(ss, 3, p.points.back());
    } else {
      die("problem file: unknown line: " + line);
    }
  }
  if (p.prismatic.empty() || p.tool.size() != 3) die("problem file: no joints or no tool");
  if (p.point_kind && p.points.empty()) die("problem file: kind point without points");
  return p;
}

// ---- the data -------------------------------------------------------------------------------
struct Data {
  int n = 0;                 // joints
  std::vector<double> q;     // N x n
  std::vector<double> x;     // N x 3 (measured)
  std::vector<int> c;        // N (point index)
  size_t rows() const { return n ? q.size() / n : 0; }
};

Data read_csv(const char* path, int n, bool point_kind) {
  std::FILE* f = std::fopen(path, "r");
  if (!f) die(std::string("cannot read ") + path);
  Data d;
  d.n = n;
  std::vector<int> qcol(n, -1);
  int xcol[3] = {-1, -1, -1}, ccol = -1, ncol = 0;
  bool header = false;
  char* buf = nullptr;
  size_t cap = 0;
  ssize_t len;
  std::vector<double> vals;
  while ((len = getline(&buf, &cap, f)) > 0) {
    if (buf[0] == '#' || buf[0] == '\n' || buf[0] == '\r') continue;
    if (!header) {
      header = true;
      std::string h(buf);
      std::istringstream ss(h);
      std::string col;
      while (std::getline(ss, col, ',')) {
        size_t a = col.find_first_not_of(" \t\r\n"), b = col.find_last_not_of(" \t\r\n");
        col = a == std::string::npos ? "" : col.substr(a, b - a + 1);
        if (col.size() > 1 && col[0] == 'q') {
          int j = std::atoi(col.c_str() + 1);
          if (j >= 1 && j <= n) qcol[j - 1] = ncol;
        } else if (col == "x" || col == "y" || col == "z") {
          xcol[col[0] - 'x'] = ncol;
        } else if (col == "constraint") {
          ccol = ncol;
        }
        ++ncol;
      }
      for (int j = 0; j < n; ++j)
        if (qcol[j] < 0) die("data: no column q" + std::to_string(j + 1));
      if (!point_kind && (xcol[0] < 0 || xcol[1] < 0 || xcol[2] < 0)) die("data: no x,y,z columns");
      vals.resize(ncol);
      continue;
    }
    char* s = buf;
    for (int k = 0; k < ncol; ++k) {
      char* e;
      vals[k] = std::strtod(s, &e);
      if (e == s) die("data: bad number in line: " + std::string(buf));
      s = e;
      while (*s == ' ' || *s == '\t') ++s;
      if (k + 1 < ncol) {
        if (*s != ',') die("data: short line: " + std::string(buf));
        ++s;
      }
    }
    for (int j = 0; j < n; ++j) d.q.push_back(vals[qcol[j]]);
    if (!point_kind) {
      for (int k = 0; k < 3; ++k) d.x.push_back(vals[xcol[k]]);
    } else {
      d.c.push_back(ccol < 0 ? 0 : static_cast<int>(vals[ccol]));
    }
  }
  std::free(buf);
  std::fclose(f);
  if (!header || d.q.empty()) die(std::string("data: no rows in ") + path);
  return d;
}

// ---- the model --------------------------------------------------------------------------------
// Tip = B * T_1 ... T_n * tool, the tool point carried back from the last link to the base.
template <int N, bool BASE>
struct Chain {
  double q[N];
  bool prismatic[N];
  bool mdh;

  template <typename T>
  void tip(const T* dh, const T* tool, const T* base, T* p) const {
    using std::cos;
    using std::sin;
    T x = tool[0], y = tool[1], z = tool[2];
    for (int i = N - 1; i >= 0; --i) {
      const T* l = dh + 4 * i;  // a, alpha, d|theta, home|offset
      const T& a = l[0];
      const T& al = l[1];
      T th, d;
      if (prismatic[i]) {
        th = l[2];
        d = T(q[i]) + l[3];
      } else {
        th = T(q[i]) - l[3];
        d = l[2];
      }
      const T ct = cos(th), st = sin(th), ca = cos(al), sa = sin(al);
      if (mdh) {  // Rx(alpha) Tx(a) Rz(theta) Tz(d)
        z += d;
        T x1 = ct * x - st * y, y1 = st * x + ct * y;
        x = x1 + a;
        y = ca * y1 - sa * z;
        z = sa * y1 + ca * z;
      } else {    // Rz(theta) Tz(d) Tx(a) Rx(alpha)
        T y1 = ca * y - sa * z, z1 = sa * y + ca * z;
        x += a;
        z = z1 + d;
        T x1 = ct * x - st * y1;
        y = st * x + ct * y1;
        x = x1;
      }
    }
    if (BASE) {  // Tr Rz(yaw) Ry(pitch) Rx(roll)
      T c = cos(base[3]), s = sin(base[3]);
      T y1 = c * y - s * z, z1 = s * y + c * z;
      c = cos(base[4]), s = sin(base[4]);
      T x1 = c * x + s * z1, z2 = -s * x + c * z1;
      c = cos(base[5]), s = sin(base[5]);
      x = c * x1 - s * y1 + base[0];
      y = s * x1 + c * y1 + base[1];
      z = z2 + base[2];
    }
    p[0] = x;
    p[1] = y;
    p[2] = z;
  }
};

template <int N, bool BASE, bool POINT>
struct TipCost;

template <int N>
struct TipCost<N, false, false> : Chain<N, false> {
  double m[3];
  template <typename T>
  bool operator()(const T* dh, const T* tool, T* r) const {
    T p[3];
    this->tip(dh, tool, static_cast<const T*>(nullptr), p);
    for (int k = 0; k < 3; ++k) r[k] = p[k] - m[k];
    return true;
  }
  static ceres::CostFunction* make(TipCost* c) {
    return new ceres::AutoDiffCostFunction<TipCost, 3, 4 * N, 3>(c);
  }
};

template <int N>
struct TipCost<N, true, false> : Chain<N, true> {
  double m[3];
  template <typename T>
  bool operator()(const T* dh, const T* tool, const T* base, T* r) const {
    T p[3];
    this->tip(dh, tool, base, p);
    for (int k = 0; k < 3; ++k) r[k] = p[k] - m[k];
    return true;
  }
  static ceres::CostFunction* make(TipCost* c) {
    return new ceres::AutoDiffCostFunction<TipCost, 3, 4 * N, 3, 6>(c);
  }
};

template <int N>
struct TipCost<N, false, true> : Chain<N, false> {
  template <typename T>
  bool operator()(const T* dh, const T* tool, const T* pt, T* r) const {
    T p[3];
    this->tip(dh, tool, static_cast<const T*>(nullptr), p);
    for (int k = 0; k < 3; ++k) r[k] = p[k] - pt[k];
    return true;
  }
  static ceres::CostFunction* make(TipCost* c) {
    return new ceres::AutoDiffCostFunction<TipCost, 3, 4 * N, 3, 3>(c);
  }
};

template <int N>
struct TipCost<N, true, true> : Chain<N, true> {
  template <typename T>
  bool operator()(const T* dh, const T* tool, const T* base, const T* pt, T* r) const {
    T p[3];
    this->tip(dh, tool, base, p);
    for (int k = 0; k < 3; ++k) r[k] = p[k] - pt[k];
    return true;
  }
  static ceres::CostFunction* make(TipCost* c) {
    return new ceres::AutoDiffCostFunction<TipCost, 3, 4 * N, 3, 6, 3>(c);
  }
};

// ---- the blocks -------------------------------------------------------------------------------
struct Block {
  std::vector<Slot> slots;
  std::vector<double> v;
};

struct Blocks {
  Block dh, tool, base;
  std::vector<Block> points;
};

Block make_block(const std::vector<Slot>& slots) {
  Block b;
  b.slots = slots;
  for (const Slot& s : slots) b.v.push_back(s.value);
  return b;
}

// Fix the constant, known and held slots of a block (none free: the whole block constant).
void fix_slots(ceres::Problem& problem, Block& b, const Problem& p) {
  std::vector<int> fixed;
  for (size_t k = 0; k < b.slots.size(); ++k) {
    const Slot& s = b.slots[k];
    if (s.name.empty() || p.flag.at(s.name) != "free") fixed.push_back(static_cast<int>(k));
  }
  if (fixed.size() == b.slots.size()) {
    problem.SetParameterBlockConstant(b.v.data());
  } else if (!fixed.empty()) {
    problem.SetManifold(b.v.data(), new ceres::SubsetManifold(static_cast<int>(b.v.size()), fixed));
  }
}

template <int N, bool BASE, bool POINT>
void add_residuals(ceres::Problem& problem, const Problem& p, const Data& d, Blocks& b) {
  using Cost = TipCost<N, BASE, POINT>;
  for (size_t r = 0; r < d.rows(); ++r) {
    auto* c = new Cost;
    c->mdh = p.mdh;
    for (int i = 0; i < N; ++i) {
      c->q[i] = d.q[r * N + i];
      c->prismatic[i] = p.prismatic[i];
    }
    std::vector<double*> blocks = {b.dh.v.data(), b.tool.v.data()};
    if (BASE) blocks.push_back(b.base.v.data());
    if constexpr (POINT) {
      int k = d.c[r];
      if (k < 0 || k >= static_cast<int>(b.points.size()))
        die("data: constraint index " + std::to_string(k) + " out of range");
      blocks.push_back(b.points[k].v.data());
    } else {
      for (int k = 0; k < 3; ++k) c->m[k] = d.x[3 * r + k];
    }
    problem.AddResidualBlock(Cost::make(c), nullptr, blocks);
  }
}

template <int N>
void add_all(ceres::Problem& problem, const Problem& p, const Data& d, Blocks& b) {
  const bool base = !p.base.empty();
  if (p.point_kind) {
    base ? add_residuals<N, true, true>(problem, p, d, b) : add_residuals<N, false, true>(problem, p, d, b);
  } else {
    base ? add_residuals<N, true, false>(problem, p, d, b) : add_residuals<N, false, false>(problem, p, d, b);
  }
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 4) {
    std::fprintf(stderr, "usage: peer_ceres PROBLEM.txt DATA.csv OUT.json [--threads K] [--verbose] [--tolerance TOL]\n");
    return 2;
  }
  int threads = 1;
  bool verbose = false;
  double tol = 0;  // 0: Ceres' defaults
  for (int k = 4; k < argc; ++k) {
    if (!std::strcmp(argv[k], "--threads") && k + 1 < argc) {
      threads = std::atoi(argv[++k]);
    } else if (!std::strcmp(argv[k], "--tolerance") && k + 1 < argc) {
      tol = std::atof(argv[++k]);
    } else if (!std::strcmp(argv[k], "--verbose")) {
      verbose = true;
    } else {
      die(std::string("unknown option ") + argv[k]);
    }
  }
  FLAGS_logtostderr = true;  // glog: no log files in /tmp, warnings (if any) on stderr
  FLAGS_minloglevel = 1;
  google::InitGoogleLogging(argv[0]);

  const Problem p = read_problem(argv[1]);
  const int n = static_cast<int>(p.prismatic.size());
  const Data d = read_csv(argv[2], n, p.point_kind);

  // Each parameter may sit in one slot only (a shared parameter would need its own block).
  std::map<std::string, int> uses;
  auto count = [&](const std::vector<Slot>& v) {
    for (const Slot& s : v)
      if (!s.name.empty() && ++uses[s.name] > 1) die("parameter " + s.name + " used in two places");
  };
  count(p.dh);
  count(p.tool);
  count(p.base);
  for (const auto& pt : p.points) count(pt);

  Blocks b;
  b.dh = make_block(p.dh);
  b.tool = make_block(p.tool);
  b.base = make_block(p.base);
  for (const auto& pt : p.points) b.points.push_back(make_block(pt));

  ceres::Problem problem;
  switch (n) {
    case 2: add_all<2>(problem, p, d, b); break;
    case 3: add_all<3>(problem, p, d, b); break;
    case 4: add_all<4>(problem, p, d, b); break;
    case 5: add_all<5>(problem, p, d, b); break;
    case 6: add_all<6>(problem, p, d, b); break;
    case 7: add_all<7>(problem, p, d, b); break;
    default: die("only 2 to 7 joints are compiled in (" + std::to_string(n) + " given)");
  }
  fix_slots(problem, b.dh, p);
  fix_slots(problem, b.tool, p);
  if (!p.base.empty()) fix_slots(problem, b.base, p);
  for (auto& pt : b.points)
    if (problem.HasParameterBlock(pt.v.data())) fix_slots(problem, pt, p);

  ceres::Solver::Options options;  // default tolerances and iteration limit
  options.minimizer_type = ceres::TRUST_REGION;
  options.trust_region_strategy_type = ceres::LEVENBERG_MARQUARDT;
  options.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  options.num_threads = threads;
  options.minimizer_progress_to_stdout = verbose;
  if (tol > 0) {  // a check of convergence only; the bench runs the defaults
    options.function_tolerance = tol;
    options.parameter_tolerance = tol;
    options.gradient_tolerance = tol * 1e-4;
    options.max_num_iterations = 500;
  }
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  if (verbose) std::fprintf(stderr, "%s\n", summary.FullReport().c_str());

  // The estimate: every parameter's value from its slot, nominals for the rest.
  std::map<std::string, double> est = p.nominal;
  auto take = [&](const Block& bl) {
    for (size_t k = 0; k < bl.slots.size(); ++k)
      if (!bl.slots[k].name.empty()) est[bl.slots[k].name] = bl.v[k];
  };
  take(b.dh);
  take(b.tool);
  take(b.base);
  for (const auto& pt : b.points) take(pt);

  std::FILE* out = std::fopen(argv[3], "w");
  if (!out) die(std::string("cannot write ") + argv[3]);
  std::fprintf(out, "{");
  for (size_t k = 0; k < p.names.size(); ++k)
    std::fprintf(out, "%s\n \"%s\": %.17g", k ? "," : "", p.names[k].c_str(), est[p.names[k]]);
  std::fprintf(out, "\n}\n");
  std::fclose(out);

  const double rms = std::sqrt(2 * summary.final_cost / d.rows());
  std::fprintf(stderr,
               "peer_ceres: %zu poses, %d free parameters, %d iterations (%d unsuccessful), %s, "
               "threads %d, residual rms %.3e m\n",
               d.rows(), summary.num_effective_parameters_reduced,
               summary.num_successful_steps + summary.num_unsuccessful_steps,
               summary.num_unsuccessful_steps, ceres::TerminationTypeToString(summary.termination_type),
               summary.num_threads_used, rms);
  return summary.IsSolutionUsable() ? 0 : 1;
}
