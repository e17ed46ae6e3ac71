#include "module.hpp"

#include <dlfcn.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <map>
#include <mutex>
#include <vector>

#include "trellis/core/error.hpp"

namespace trellis::detail {

namespace {

// The folder holding libtrellis (the file this function is compiled into).
std::string library_dir() {
  Dl_info info{};
  if (::dladdr(reinterpret_cast<void*>(&library_dir), &info) == 0 || !info.dli_fname) return {};
  return std::filesystem::path(info.dli_fname).parent_path().string();
}

std::vector<std::string> search_dirs() {
  std::vector<std::string> dirs;
  if (const char* env = std::getenv("TRELLIS_MODULE_DIR"); env && *env) dirs.emplace_back(env);
  const std::string own = library_dir();
  dirs.push_back((own.empty() ? std::string("trellis") : own + "/trellis"));
  return dirs;
}

const ModuleHeader* open_module(const std::string& name, std::size_t table_size) {
  const std::string file = "trellis_" + name + ".so", entry = "trellis_module_" + name;
  std::string tried;
  for (const auto& dir : search_dirs()) {
    const std::string path = dir + "/" + file;
    void* handle = ::dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (!handle) {
      const char* why = ::dlerror();
      tried += "\n  " + (why ? std::string(why) : path + ": cannot be loaded");
      continue;
    }
    using Entry = const ModuleHeader* (*)();
    auto fn = reinterpret_cast<Entry>(::dlsym(handle, entry.c_str()));
    const ModuleHeader* header = fn ? fn() : nullptr;
    if (!header) {
      tried += "\n  " + path + ": no " + entry + "()";
    } else if (std::strcmp(header->version, TRELLIS_VERSION) != 0 || header->size != table_size) {
      tried +=
          "\n  " + path + ": built for Trellis " + header->version + ", not " + TRELLIS_VERSION;
    } else {
      return header;  // never unloaded: fields and meshes may point into its code
    }
    ::dlclose(handle);
  }
  throw Error("cannot load the Trellis module " + file + "; tried:" + tried +
              "\n  (set TRELLIS_MODULE_DIR to the folder holding " + file + ")");
}

}  // namespace

const ModuleHeader& load_module(const std::string& name, std::size_t table_size) {
  // The one process-wide state in the library: a module is a process-wide resource.
  static std::mutex mutex;
  static std::map<std::string, const ModuleHeader*> loaded;
  std::lock_guard lock(mutex);
  auto it = loaded.find(name);
  if (it == loaded.end()) it = loaded.emplace(name, open_module(name, table_size)).first;
  return *it->second;
}

}  // namespace trellis::detail
