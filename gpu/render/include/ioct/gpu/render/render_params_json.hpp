// The render parameters as JSON (docs/live-view.md): what the view socket, the pages and the HTTP
// API read and change. One place turns JSON into a RenderConfig and validates it, so every client
// gets the same error for the same bad value: ConfigError naming the key as the configuration
// does ("render.enhanced.kg1 = -1: must be at least 0"), for unknown keys, wrong types and values
// out of range alike. The ranges are RenderConfig::validate()'s; none are written here.
#pragma once

#include <nlohmann/json.hpp>

#include "ioct/gpu/render/render_config.hpp"

namespace ioct::gpu::render {

// Every parameter a viewer may see or change:
//   {"mode", "preset", "view": {...}, "enhanced": {..., "transfer": {"window", "opacity"}},
//    "layer_aware": {...}, "slice": {"bscan"}}
nlohmann::json to_json(const RenderConfig& config);

// `base` with `changes` (any subset of to_json's keys) applied and validated. A "preset" is applied
// first (the enhanced parameters become enhanced_preset's), then the other keys over it. Throws
// ConfigError naming the first bad key; `base` is never modified.
RenderConfig apply_render_changes(const RenderConfig& base, const nlohmann::json& changes);

// The same for a viewer's own camera: only the "view" object may be changed (ConfigError naming
// any other key).
RenderConfig apply_camera_changes(const RenderConfig& base, const nlohmann::json& changes);

}  // namespace ioct::gpu::render
