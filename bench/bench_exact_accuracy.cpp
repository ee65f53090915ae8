// Accuracy of the exact engine and of peer images against the independent oracle (tests/oracle: dense sampling with
// point location, double precision), the measure the issue asks for: RMS and PSNR over RGB at 256 x 256.
//
//   bench_exact_accuracy MESH FIELD CAMERA.json TF.json OUT_DIR [PEER.pfm ...]
//
// Renders the oracle (saved as OUT_DIR/oracle.pfm) and the exact engine with its default early termination (0.99)
// and without it (1.0), then prints one JSON line per image: {"image", "rms", "psnr_db", "max_abs", "ssim"}.
#include <cstdio>
#include <string>
#include <vector>

#include "oracle/reference_renderer.h"
#include "ugvr/ugvr.h"

using namespace ugvr;

namespace {

void report(const std::string& name, const Image& image, const Image& oracle) {
  const ImageDifference d = compare_images(image, oracle);
  std::printf("{\"image\": \"%s\", \"rms\": %.3e, \"psnr_db\": %.2f, \"max_abs\": %.3e, \"ssim\": %.5f}\n",
              name.c_str(), d.rms, d.psnr_db, d.max_abs, ssim(image, oracle));
  std::fflush(stdout);
}

}  // namespace

int main(int argc, char** argv) try {
  if (argc < 6) {
    std::fprintf(stderr, "usage: %s MESH FIELD CAMERA.json TF.json OUT_DIR [PEER.pfm ...]\n", argv[0]);
    return 2;
  }
  const auto ds = std::make_shared<const Dataset>(read_dataset(std::vector<std::string>{argv[1]}));
  const std::string field = argv[2];
  const Camera camera = read_camera(argv[3]);
  const TransferFunction tf = read_paraview_preset(argv[4]);
  const std::string out = argv[5];
  FrameRequest request;
  request.camera = camera;
  request.tf = tf;
  request.settings.width = request.settings.height = 256;
  request.settings.field = field;

  oracle::ReferenceRenderer reference(*ds, field);
  const Image oracle_image = reference.render(camera, tf, request.settings);
  write_pfm(out + "/oracle.pfm", oracle_image);
  write_png(out + "/oracle.png", oracle_image);

  RendererConfig config;
  config.engine = "exact";
  const std::unique_ptr<Renderer> exact_engine = make_renderer(ds, config);
  const Image exact = exact_engine->render(request).image;
  write_pfm(out + "/exact-256.pfm", exact);
  report("ugvr exact (early termination 0.99)", exact, oracle_image);
  request.settings.early_termination_opacity = 1;
  report("ugvr exact (no early termination)", exact_engine->render(request).image, oracle_image);
  for (int i = 6; i < argc; ++i) report(argv[i], read_pfm(argv[i]), oracle_image);
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "bench_exact_accuracy: %s\n", e.what());
  return 1;
}
