#include "instant_motion_tracking/io/init_spec.h"

#include "instant_motion_tracking/core/item_requests.h"
#include "instant_motion_tracking/core/planar/image_target_detector.h"
#include "instant_motion_tracking/core/planar/planar_target.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <charconv>
#include <filesystem>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <sstream>
#include <stdexcept>
#include <type_traits>

namespace imt {
namespace {

namespace fs = std::filesystem;

// Shortest text that reads back as `v` ("1234.5", not "1234.500000").
std::string shortest(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, r.ptr);
}

std::string fixed6(double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.6f", v);
  return buf;
}

// How a node that is not what we expected looks, for messages.
std::string describe(const YAML::Node& n) {
  if (!n || n.IsNull()) return "nothing";
  if (n.IsSequence()) return "a list of " + std::to_string(n.size());
  if (n.IsMap()) return "a mapping";
  std::string s = n.Scalar();
  if (s.size() > 40) s = s.substr(0, 37) + "...";
  return "'" + s + "'";
}

// Thrown inside the parser only; parseInitSpec turns it into its error.
struct InitError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

// Reads one entry of a list, naming it in every error.
class EntryReader {
 public:
  EntryReader(const YAML::Node& node, std::string where, std::vector<std::string> keys)
      : node_(node), where_(std::move(where)), keys_(std::move(keys)) {}

  [[noreturn]] void fail(const std::string& what) const {
    throw InitError(where_ + (id_ ? " (id " + std::to_string(id_) + ")" : "") + ": " + what);
  }

  // Checks the entry is a mapping, reads its id and rejects unknown keys.
  uint32_t start() {
    if (!node_.IsMap()) fail("expected a mapping with " + keyList() + ", got " + describe(node_));
    const YAML::Node n = node_["id"];
    if (!n) fail("missing field 'id'");
    long long id = 0;
    bool integer = false;
    if (n.IsScalar()) {
      try {
        id = n.as<long long>();
        integer = true;
      } catch (const YAML::Exception&) {
      }
    }
    if (!integer || id <= 0 || id > std::numeric_limits<uint32_t>::max())
      fail("id must be a positive integer, got " + describe(n));
    id_ = static_cast<uint32_t>(id);
    for (const auto& kv : node_) {
      const std::string key = kv.first.IsScalar() ? kv.first.Scalar() : describe(kv.first);
      if (std::find(keys_.begin(), keys_.end(), key) == keys_.end())
        fail("unknown key '" + key + "' (expected " + keyList() + ")");
    }
    return id_;
  }

  const YAML::Node field(const char* name, bool required = true) const {
    const YAML::Node n = node_[name];
    if (!n && required) fail(std::string("missing field '") + name + "'");
    return n;
  }

  // A number; NaN and infinities are refused unless `any` (an item's values,
  // which the item's validator judges as every door's: item_requests.h).
  double number(const YAML::Node& n, const std::string& name, bool any = false) const {
    double v = 0;
    bool ok = false;
    if (n.IsScalar()) {
      try {
        v = n.as<double>();
        ok = true;
      } catch (const YAML::Exception&) {
      }
    }
    if (!ok) fail(name + " must be a number, got " + describe(n));
    if (!any && !std::isfinite(v)) fail(name + " must be finite, got " + describe(n));
    return v;
  }

  // A list of exactly `N` numbers, any of them NaN or infinite (an item's
  // values: its validator names those).
  template <size_t N>
  std::array<double, N> numbers(const YAML::Node& n, const std::string& name) const {
    if (!n.IsSequence())
      fail(name + " must be a list of " + std::to_string(N) + " numbers, got " + describe(n));
    if (n.size() != N)
      fail(name + " must have " + std::to_string(N) + " numbers, got " + std::to_string(n.size()));
    std::array<double, N> out{};
    for (size_t i = 0; i < N; ++i) out[i] = number(n[i], name + "[" + std::to_string(i) + "]", /*any=*/true);
    return out;
  }

  double stamp() const {
    const double s = number(field("stamp"), "stamp");
    if (s < 0) fail("stamp must not be negative, got " + shortest(s));
    return s;
  }

 private:
  std::string keyList() const {
    std::string s;
    for (size_t i = 0; i < keys_.size(); ++i) s += (i ? ", " : "") + keys_[i];
    return s;
  }

  const YAML::Node node_;
  std::string where_;
  std::vector<std::string> keys_;
  uint32_t id_ = 0;
};

// `kind` names an item of the list in the core's words ("region").
template <class Entry, class ReadFn>
std::vector<Entry> readList(const YAML::Node& root, const char* list, const char* kind,
                            const std::vector<std::string>& keys, ReadFn read,
                            std::map<uint32_t, std::string>* ids = nullptr) {
  std::vector<Entry> out;
  const YAML::Node n = root[list];
  if (!n || n.IsNull()) return out;  // "regions:" with nothing under it: no entries
  if (!n.IsSequence())
    throw InitError(std::string(list) + " must be a list of entries, got " + describe(n));
  // id -> its first entry; `ids` (when given) is shared with other lists.
  std::map<uint32_t, std::string> own;
  std::map<uint32_t, std::string>& space = ids ? *ids : own;
  for (size_t i = 0; i < n.size(); ++i) {
    const std::string where = std::string(list) + "[" + std::to_string(i) + "]";
    EntryReader r(n[i], where, keys);
    Entry e;
    e.id = r.start();
    const auto [it, fresh] = space.emplace(e.id, where);
    if (!fresh) r.fail(alreadyTrackedError(kind, e.id) + " (also " + it->second + ")");
    if constexpr (!std::is_same_v<Entry, ImageTargetInit>) e.stamp = r.stamp();
    read(r, &e);
    out.push_back(e);
  }
  return out;
}

InitSpec parseRoot(const YAML::Node& root, const std::string& source) {
  static const char* kLists = "regions, planar_targets, image_targets and/or anchors";
  if (!root || root.IsNull())
    throw InitError(std::string("empty (expected a mapping with ") + kLists + ")");
  if (!root.IsMap())
    throw InitError(std::string("expected a mapping with ") + kLists + ", got " + describe(root));
  for (const auto& kv : root) {
    const std::string key = kv.first.IsScalar() ? kv.first.Scalar() : describe(kv.first);
    if (key != "regions" && key != "planar_targets" && key != "image_targets" && key != "anchors")
      throw InitError("unknown list '" + key + "' (expected regions, planar_targets, image_targets, anchors)");
  }
  InitSpec spec;
  // Each item is checked by its kind's validator, the one every door runs
  // (core/item_requests.h), so that a bad entry gets the services' answer
  // before the bag is read; what needs the frame is checked when track_bag
  // adds it.
  spec.regions = readList<RegionInit>(
      root, "regions", "region", {"id", "stamp", "box"}, [](const EntryReader& r, RegionInit* e) {
        e->box = r.numbers<4>(r.field("box"), "box");
        const cv::Rect2d box(e->box[0], e->box[1], e->box[2], e->box[3]);
        if (const std::string why = validateRegionRequest(e->id, box); !why.empty()) r.fail(why);
      });
  std::map<uint32_t, std::string> target_ids;  // planar and image targets share them
  spec.planar_targets = readList<PlanarTargetInit>(
      root, "planar_targets", "planar target", {"id", "stamp", "corners", "size"},
      [](const EntryReader& r, PlanarTargetInit* e) {
        const YAML::Node c = r.field("corners");
        if (!c.IsSequence())
          r.fail("corners must be a list of 4 points [x, y], got " + describe(c));
        if (c.size() != 4)
          r.fail("corners must have 4 points (TL, TR, BR, BL), got " + std::to_string(c.size()));
        for (size_t i = 0; i < 4; ++i)
          e->corners[i] = r.numbers<2>(c[i], "corners[" + std::to_string(i) + "]");
        e->size = r.numbers<2>(r.field("size"), "size");
        std::array<cv::Point2d, 4> quad;
        for (size_t i = 0; i < 4; ++i) quad[i] = cv::Point2d(e->corners[i][0], e->corners[i][1]);
        if (const std::string why = validateTargetRequest(quad, e->size[0], e->size[1]); !why.empty())
          r.fail(why);
      },
      &target_ids);
  const std::string dir = fs::path(source).parent_path().string();
  spec.image_targets = readList<ImageTargetInit>(
      root, "image_targets", "planar target", {"id", "image", "size"},
      [&dir](const EntryReader& r, ImageTargetInit* e) {
        const YAML::Node image = r.field("image");
        if (!image.IsScalar() || image.Scalar().empty())
          r.fail("image must be a file path, got " + describe(image));
        e->image = image.Scalar();
        e->size = r.numbers<2>(r.field("size"), "size");
        if (const std::string why = validateTargetSize(e->size[0], e->size[1]); !why.empty()) r.fail(why);
        const fs::path p(e->image);
        e->path = p.is_absolute() || dir.empty() ? p.string() : (fs::path(dir) / p).string();
        std::string why;
        e->picture = ImageTargetDetector::readPicture(e->path, &why);
        if (e->picture.empty()) r.fail(why);
      },
      &target_ids);
  spec.anchors = readList<AnchorInit>(
      root, "anchors", "anchor", {"id", "stamp", "point", "depth"}, [](const EntryReader& r, AnchorInit* e) {
        e->point = r.numbers<2>(r.field("point"), "point");
        const YAML::Node d = r.field("depth", /*required=*/false);
        if (d) e->depth = r.number(d, "depth", /*any=*/true);  // 0: the default, as add_anchor's
        if (const std::string why = validateAnchorRequest(cv::Point2d(e->point[0], e->point[1]), e->depth);
            !why.empty())
          r.fail(why);
      });
  return spec;
}

}  // namespace

bool parseInitSpec(const std::string& text, const std::string& source, InitSpec* spec,
                   std::string* error) {
  try {
    YAML::Node root;
    try {
      root = YAML::Load(text);
    } catch (const YAML::ParserException& e) {
      *error = source + ": invalid YAML at line " + std::to_string(e.mark.line + 1) +
               ", column " + std::to_string(e.mark.column + 1) + ": " + e.msg;
      return false;
    }
    *spec = parseRoot(root, source);
    return true;
  } catch (const InitError& e) {
    *error = source + ": " + e.what();
  } catch (const std::exception& e) {  // yaml-cpp oddities (e.g. complex keys)
    *error = source + ": cannot read: " + e.what();
  }
  return false;
}

bool loadInitSpecFile(const std::string& path, InitSpec* spec, std::string* error) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    *error = path + ": cannot open the init file";
    return false;
  }
  std::stringstream ss;
  ss << in.rdbuf();
  if (in.bad()) {
    *error = path + ": cannot read the init file";
    return false;
  }
  return parseInitSpec(ss.str(), path, spec, error);
}

int resolveStamp(double stamp, const std::vector<double>& frame_stamps,
                 const std::string& range_name, std::string* error) {
  constexpr double kSlack = 1e-6;  // s; stamps copied from CSVs carry 6 decimals
  if (frame_stamps.empty()) {
    *error = "stamp " + shortest(stamp) + " cannot be resolved: no frames in " + range_name;
    return -1;
  }
  // Distinct stamps, ascending, each with the first frame index holding it.
  std::vector<std::pair<double, int>> u;
  u.reserve(frame_stamps.size());
  for (size_t i = 0; i < frame_stamps.size(); ++i)
    u.emplace_back(frame_stamps[i], static_cast<int>(i));
  std::sort(u.begin(), u.end());
  u.erase(std::unique(u.begin(), u.end(),
                      [](const auto& a, const auto& b) { return a.first == b.first; }),
          u.end());

  // The frame interval: the median spacing of the distinct stamps, so that a
  // few dropped frames (a gap) do not widen it.
  double interval = 0;
  if (u.size() > 1) {
    std::vector<double> d(u.size() - 1);
    for (size_t i = 0; i + 1 < u.size(); ++i) d[i] = u[i + 1].first - u[i].first;
    std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
    interval = d[d.size() / 2];
  }
  const double tolerance = 0.5 * interval + kSlack;

  const auto it = std::lower_bound(u.begin(), u.end(), std::make_pair(stamp, -1));
  size_t j = static_cast<size_t>(it - u.begin());
  if (j == u.size() || (j > 0 && stamp - u[j - 1].first <= u[j].first - stamp)) --j;
  if (std::abs(stamp - u[j].first) <= tolerance) return u[j].second;

  if (stamp < u.front().first || stamp > u.back().first) {
    *error = "stamp " + shortest(stamp) + " is outside " + range_name + " (frames " +
             fixed6(u.front().first) + " .. " + fixed6(u.back().first) + ")";
  } else {
    *error = "stamp " + shortest(stamp) + " is not within half a frame of any frame (nearest " +
             fixed6(u[j].first) + ")";
  }
  return -1;
}

bool resolveInitStamps(const std::vector<double>& frame_stamps, const std::string& source,
                       const std::string& range_name, InitSpec* spec, std::string* error) {
  auto resolve = [&](const char* list, auto& entries) {
    for (size_t i = 0; i < entries.size(); ++i) {
      std::string why;
      const int f = resolveStamp(entries[i].stamp, frame_stamps, range_name, &why);
      if (f < 0) {
        *error = source + ": " + list + "[" + std::to_string(i) + "] (id " +
                 std::to_string(entries[i].id) + "): " + why;
        return false;
      }
      entries[i].frame = f;
    }
    return true;
  };
  InitSpec s = *spec;
  if (!resolve("regions", s.regions) || !resolve("planar_targets", s.planar_targets) ||
      !resolve("anchors", s.anchors))
    return false;
  *spec = s;
  return true;
}

}  // namespace imt
