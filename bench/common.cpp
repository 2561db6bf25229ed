#include "common.hpp"

#include <tinyxml2.h>

#include <Eigen/Core>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

namespace cosserat::bench {

double median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

double time_median(const std::function<void()>& f, int min_reps, double min_time, int max_reps) {
  std::vector<double> t;
  double spent = 0.0;
  // batches so that the clock's resolution does not matter for sub-microsecond calls
  int batch = 1;
  {
    const double t0 = now_seconds();
    f();
    const double one = now_seconds() - t0;
    if (one < 1e-5) batch = std::max(1, static_cast<int>(1e-5 / std::max(one, 1e-9)));
  }
  while ((static_cast<int>(t.size()) < min_reps || spent < min_time) && static_cast<int>(t.size()) * batch < max_reps) {
    const double t0 = now_seconds();
    for (int i = 0; i < batch; ++i) f();
    const double dt = now_seconds() - t0;
    spent += dt;
    t.push_back(dt / batch);
  }
  return median(t);
}

json machine_info() {
  json j;
  std::string cpu = "unknown";
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("model name", 0) == 0) {
      cpu = line.substr(line.find(':') + 2);
      break;
    }
  j["cpu"] = cpu;
  j["hardware_threads"] = std::thread::hardware_concurrency();
#if defined(__clang__)
  j["compiler"] = std::string("clang ") + __clang_version__;
#elif defined(__GNUC__)
  j["compiler"] = std::string("gcc ") + __VERSION__;
#endif
#ifdef NDEBUG
  std::string build = "release (NDEBUG)";
#else
  std::string build = "debug (assertions on)";
#endif
  // the instruction set our code was compiled for (COSSERAT_NATIVE); MuJoCo is the distribution's
  // library, compiled for the baseline of its architecture
#if defined(__AVX2__) && defined(__FMA__)
  build += ", our code with AVX2 and FMA (x86-64-v3), MuJoCo as packaged";
#else
  build += ", our code for the baseline instruction set, MuJoCo as packaged";
#endif
  j["build"] = build;
  j["mujoco"] = mj_versionString();
  j["eigen"] = std::to_string(EIGEN_WORLD_VERSION) + "." + std::to_string(EIGEN_MAJOR_VERSION) + "." +
               std::to_string(EIGEN_MINOR_VERSION);
  std::ifstream la("/proc/loadavg");
  std::string load;
  std::getline(la, load);
  j["loadavg_at_start"] = load;
  char date[64];
  const std::time_t now = std::time(nullptr);
  std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
  j["date"] = date;
  return j;
}

void write_json(const std::string& path, const json& j) {
  const std::filesystem::path p(path);
  if (p.has_parent_path()) std::filesystem::create_directories(p.parent_path());
  std::ofstream out(path);
  out << j.dump(1) << "\n";
  std::printf("wrote %s\n", path.c_str());
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

bool file_exists(const std::string& path) { return std::filesystem::exists(path); }

// ------------------------------------------------------------------------------ MJCF edits --

namespace {

using tinyxml2::XMLDocument;
using tinyxml2::XMLElement;

void parse(XMLDocument& doc, const std::string& xml) {
  if (doc.Parse(xml.c_str(), xml.size()) != tinyxml2::XML_SUCCESS) throw std::runtime_error("MJCF parse error");
}
std::string print(XMLDocument& doc) {
  tinyxml2::XMLPrinter p;
  doc.Print(&p);
  return p.CStr();
}
template <class F>
void visit(XMLElement* e, const F& f) {
  for (XMLElement* c = e->FirstChildElement(); c;) {
    XMLElement* next = c->NextSiblingElement();
    if (!f(e, c)) visit(c, f);
    c = next;
  }
}

}  // namespace

std::string set_rod_attr(const std::string& xml, const std::string& attr, const std::string& value,
                         const std::string& rod) {
  XMLDocument doc;
  parse(doc, xml);
  visit(doc.RootElement(), [&](XMLElement*, XMLElement* c) {
    if (std::strcmp(c->Name(), "cosserat") == 0 && (rod.empty() || (c->Attribute("name") && rod == c->Attribute("name")))) {
      if (value.empty())
        c->DeleteAttribute(attr.c_str());
      else
        c->SetAttribute(attr.c_str(), value.c_str());
    }
    return false;
  });
  return print(doc);
}

namespace {

// Whether two <section> elements are the same section: the same attributes (no `length` on
// either: such sections share the rod's free length evenly) and no children.
bool same_free_section(const XMLElement* a, const XMLElement* b) {
  if (a->Attribute("length") || b->Attribute("length") || a->FirstChild() || b->FirstChild()) return false;
  int na = 0, nb = 0;
  for (const tinyxml2::XMLAttribute* x = a->FirstAttribute(); x; x = x->Next(), ++na) {
    const char* v = b->Attribute(x->Name());
    if (!v || std::strcmp(v, x->Value()) != 0) return false;
  }
  for (const tinyxml2::XMLAttribute* x = b->FirstAttribute(); x; x = x->Next()) ++nb;
  return na == nb;
}

}  // namespace

std::string refine_sections(const std::string& xml, int k) {
  if (k == 0 || k == -1) throw std::invalid_argument("refine_sections: k must be >= 1 or <= -2");
  XMLDocument doc;
  parse(doc, xml);
  visit(doc.RootElement(), [&](XMLElement*, XMLElement* c) {
    if (std::strcmp(c->Name(), "cosserat") != 0) return false;
    std::vector<XMLElement*> secs;
    for (XMLElement* e = c->FirstChildElement("section"); e; e = e->NextSiblingElement("section")) secs.push_back(e);
    if (k < 0) {
      // coarsening: every run of identical length-free sections, m = -k of them into one (the
      // run's sections then share the rod's free length in fewer, longer pieces: the same rest
      // shape where they have the same rest strain)
      const int m = -k;
      int kept = 0;
      for (size_t i = 0; i < secs.size();) {
        size_t j = i + 1;
        while (j < secs.size() && same_free_section(secs[i], secs[j])) ++j;
        const size_t run = j - i;
        if (run > 1 || !secs[i]->Attribute("length")) {
          if (run % m != 0)
            throw std::invalid_argument("refine_sections: a run of " + std::to_string(run) +
                                        " identical sections cannot be merged " + std::to_string(m) + " to one");
          for (size_t q = i; q < j; ++q)
            if ((q - i) % m != 0) c->DeleteChild(secs[q]);
          kept += static_cast<int>(run) / m;
        } else {
          ++kept;
        }
        i = j;
      }
      if (secs.empty()) {
        const int n0 = c->IntAttribute("sections", 1);
        if (n0 % m != 0)
          throw std::invalid_argument("refine_sections: " + std::to_string(n0) + " sections cannot be merged " +
                                      std::to_string(m) + " to one");
        c->SetAttribute("sections", n0 / m);
      } else if (c->Attribute("sections")) {
        c->SetAttribute("sections", kept);
      }
      return true;
    }
    if (secs.empty()) {
      c->SetAttribute("sections", c->IntAttribute("sections", 1) * k);
      return true;
    }
    if (c->Attribute("sections")) c->SetAttribute("sections", static_cast<int>(secs.size()) * k);
    for (XMLElement* e : secs) {
      if (e->Attribute("length")) e->SetAttribute("length", e->DoubleAttribute("length") / k);
      XMLElement* at = e;
      for (int i = 1; i < k; ++i) {
        XMLElement* copy = e->DeepClone(&doc)->ToElement();
        c->InsertAfterChild(at, copy);
        at = copy;
      }
    }
    return true;
  });
  return print(doc);
}

std::string set_option(const std::string& xml, const std::string& attr, const std::string& value) {
  XMLDocument doc;
  parse(doc, xml);
  XMLElement* root = doc.RootElement();
  XMLElement* opt = root->FirstChildElement("option");
  if (!opt) {
    opt = doc.NewElement("option");
    root->InsertFirstChild(opt);
  }
  opt->SetAttribute(attr.c_str(), value.c_str());
  return print(doc);
}

std::string remove_named(const std::string& xml, const std::string& tag, const std::string& name) {
  XMLDocument doc;
  parse(doc, xml);
  visit(doc.RootElement(), [&](XMLElement* parent, XMLElement* c) {
    if (tag == c->Name() && c->Attribute("name") && name == c->Attribute("name")) {
      parent->DeleteChild(c);
      return true;
    }
    return false;
  });
  return print(doc);
}

std::string remove_all(const std::string& xml, const std::string& tag) {
  XMLDocument doc;
  parse(doc, xml);
  visit(doc.RootElement(), [&](XMLElement* parent, XMLElement* c) {
    if (tag == c->Name()) {
      parent->DeleteChild(c);
      return true;
    }
    return false;
  });
  return print(doc);
}

std::string set_named_attr(const std::string& xml, const std::string& tag, const std::string& name,
                           const std::string& attr, const std::string& value) {
  XMLDocument doc;
  parse(doc, xml);
  bool found = false;
  visit(doc.RootElement(), [&](XMLElement*, XMLElement* c) {
    if (tag == c->Name() && c->Attribute("name") && name == c->Attribute("name")) {
      c->SetAttribute(attr.c_str(), value.c_str());
      found = true;
    }
    return false;
  });
  if (!found) throw std::runtime_error("no <" + tag + " name=\"" + name + "\">");
  return print(doc);
}

mjModel* load_mujoco_string(const std::string& xml, const std::string& path) {
  auto vfs = std::make_unique<mjVFS>();
  mj_defaultVFS(vfs.get());
  if (mj_makeEmptyFileVFS(vfs.get(), path.c_str(), static_cast<int>(xml.size())))
    throw std::runtime_error("cannot create a virtual file");
  std::memcpy(vfs->filedata[vfs->nfile - 1], xml.data(), xml.size());
  char error[1024] = "";
  mjModel* m = mj_loadXML(path.c_str(), vfs.get(), error, sizeof error);
  mj_deleteVFS(vfs.get());
  if (!m) throw std::runtime_error(path + ": MuJoCo: " + error);
  return m;
}

// --------------------------------------------------------------------------- simulations --

const char* method_name(Method m) {
  switch (m) {
    case Method::Euler: return "euler";
    case Method::Implicit: return "implicit";
    case Method::RK4: return "rk4";
    case Method::Trapezoidal: return "trapezoidal";
    case Method::TrapezoidalLinear: return "trapezoidal-lin";
    case Method::GeneralizedAlpha: return "genalpha";
    case Method::ImplicitNewton: return "implicit-newton";
    case Method::Midpoint: return "midpoint";
    case Method::Rosenbrock: return "rosenbrock";
  }
  return "?";
}

namespace {

class RodSim : public Sim {
 public:
  RodSim(const std::string& xml, const std::string& path, Method method, double h)
      : scene_(mj::load_scene_string(xml, path)), data_(*scene_) {
    scene_->m->opt.timestep = h;
    switch (method) {
      case Method::Euler: integ_ = Integrator::Euler; break;
      case Method::RK4: integ_ = Integrator::RK4; break;
      case Method::Implicit: integ_ = Integrator::Implicit; break;
      case Method::ImplicitNewton:
        integ_ = Integrator::Implicit;
        scene_->newton_iterations = 10;
        break;
      case Method::Trapezoidal: integ_ = Integrator::Trapezoidal; break;
      case Method::TrapezoidalLinear:
        integ_ = Integrator::Trapezoidal;
        scene_->newton_iterations = 0;
        break;
      case Method::GeneralizedAlpha: integ_ = Integrator::GeneralizedAlpha; break;
      case Method::Midpoint: integ_ = Integrator::Midpoint; break;
      case Method::Rosenbrock: integ_ = Integrator::Rosenbrock; break;
    }
    scene_->step_tol = rod_sim_options().step_tol;
    scene_->newton_refresh = rod_sim_options().newton_refresh;
  }
  const mjModel* m() const override { return scene_->m; }
  mjData* d() override { return data_.d; }
  bool step() override { return mj::step(*scene_, data_, integ_) == Status::Ok; }
  void positions() override { mj::fwd_position(*scene_, data_); }
  void reset() override { mj::reset(*scene_, data_); }
  double energy(double* kinetic) override {
    const mj::SceneEnergy e = mj::energy(*scene_, data_);
    if (kinetic) *kinetic = e.kinetic;
    return e.total();
  }
  mj::Scene* scene() { return scene_.get(); }
  mj::SceneData* data() { return &data_; }

 private:
  std::unique_ptr<mj::Scene> scene_;
  mj::SceneData data_;
  Integrator integ_;
};

class MujocoSim : public Sim {
 public:
  MujocoSim(const std::string& xml, const std::string& path, Method method, double h) {
    m_ = load_mujoco_string(xml, path);
    m_->opt.timestep = h;
    m_->opt.integrator = method == Method::Euler ? mjINT_EULER : method == Method::RK4 ? mjINT_RK4 : mjINT_IMPLICIT;
    d_ = mj_makeData(m_);
  }
  ~MujocoSim() override {
    mj_deleteData(d_);
    mj_deleteModel(m_);
  }
  const mjModel* m() const override { return m_; }
  mjData* d() override { return d_; }
  bool step() override {
    const int bad = d_->warning[mjWARN_BADQACC].number;
    mj_step(m_, d_);
    if (d_->warning[mjWARN_BADQACC].number != bad) return false;  // MuJoCo reset the state
    for (int i = 0; i < m_->nv; ++i)
      if (!std::isfinite(d_->qvel[i]) || std::abs(d_->qvel[i]) > 1e10) return false;
    return true;
  }
  void positions() override { mj_fwdPosition(m_, d_); }
  void reset() override { mj_resetData(m_, d_); }
  double energy(double* kinetic) override {
    const int save = m_->opt.enableflags;
    m_->opt.enableflags |= mjENBL_ENERGY;
    mj_energyPos(m_, d_);
    mj_energyVel(m_, d_);
    m_->opt.enableflags = save;
    if (kinetic) *kinetic = d_->energy[1];
    return d_->energy[0] + d_->energy[1];
  }

 private:
  mjModel* m_ = nullptr;
  mjData* d_ = nullptr;
};

}  // namespace

RodSimOptions& rod_sim_options() {
  static RodSimOptions options;
  return options;
}

std::unique_ptr<Sim> make_rod_sim(const std::string& xml, const std::string& path, Method method, double h) {
  return std::make_unique<RodSim>(xml, path, method, h);
}
std::unique_ptr<Sim> make_mujoco_sim(const std::string& xml, const std::string& path, Method method, double h) {
  return std::make_unique<MujocoSim>(xml, path, method, h);
}
const mj::Scene* rod_scene(Sim& s) {
  auto* r = dynamic_cast<RodSim*>(&s);
  return r ? r->scene() : nullptr;
}
mj::SceneData* rod_scene_data(Sim& s) {
  auto* r = dynamic_cast<RodSim*>(&s);
  return r ? r->data() : nullptr;
}

Trajectory run(Sim& sim, double T, double h, double every, const std::vector<int>& sites, const Control& control,
               bool record_energy, const std::vector<int>& bodies) {
  Trajectory tr;
  const long nsteps = std::lround(T / h);
  const long stride = std::max(1L, std::lround(every / h));
  auto sample = [&] {
    sim.positions();
    tr.t.push_back(sim.time());
    std::vector<Vec3> p;
    for (int s : sites) p.push_back(sim.site(s));
    for (int b : bodies) p.push_back(sim.body(b));
    tr.p.push_back(std::move(p));
    if (record_energy) {
      double k = 0;
      tr.energy.push_back(sim.energy(&k));
      tr.kinetic.push_back(k);
    }
  };
  sample();
  double wall = 0.0;
  for (long k0 = 0; k0 < nsteps && !tr.diverged; k0 += stride) {
    const long k1 = std::min(nsteps, k0 + stride);
    const double t0 = now_seconds();
    for (long k = k0; k < k1; ++k) {
      if (control) control(sim.time(), sim.m(), sim.d());
      ++tr.steps;
      if (!sim.step()) {
        tr.diverged = true;
        break;
      }
    }
    wall += now_seconds() - t0;
    if (!tr.diverged && k1 % stride == 0) sample();
  }
  tr.wall = wall;
  return tr;
}

}  // namespace cosserat::bench
