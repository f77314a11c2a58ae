// STUB: to be replaced by the real implementation.
#include "formats/scene_xml.h"
namespace iris {
Scene load_scene(const std::string& path, const SceneLoadOptions&) { throw SceneError(path + ": not implemented"); }
}  // namespace iris
