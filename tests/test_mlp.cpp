#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include <nlohmann/json.hpp>

#include "train/mlp.hpp"

using atacom::Mlp;
using atacom::MlpConfig;
using atacom::Rng;

TEST_CASE("mlp: an ensemble member computes what a lone network computes", "[mlp]") {
  MlpConfig cfg{{5, 4}, atacom::Activation::Tanh};
  Mlp<double> ens(3, 2, cfg, 2), one(3, 2, cfg, 1);
  Rng rng(1, 0);
  ens.init(rng);
  // copy member 1 of the ensemble into the lone network, layer by layer
  const int widths[] = {3, 5, 4, 2};
  size_t eo = 0, oo = 0;
  for (int l = 0; l < 3; ++l) {
    const int in = widths[l], out = widths[l + 1];
    for (int k = 0; k < in * out; ++k) one.params()[oo + size_t(k)] = ens.params()[eo + size_t(in * out + k)];
    eo += size_t(2 * in * out);
    oo += size_t(in * out);
    for (int k = 0; k < out; ++k) one.params()[oo + size_t(k)] = ens.params()[eo + size_t(out + k)] = 0.1 * k;
    eo += size_t(2 * out);
    oo += size_t(out);
  }
  std::vector<double> x = {0.1, -0.4, 0.9, 0.3, 0.2, -0.7};
  atacom::Tape<double> t;
  const auto ye = t.value(ens.forward(t, t.constant(x.data(), 2, 3), false));
  const auto yo = t.value(one.forward(t, t.constant(x.data(), 2, 3), false));
  for (int i = 0; i < 2; ++i)
    for (int j = 0; j < 2; ++j) REQUIRE(ye(i, 2 + j) == Approx(yo(i, j)).epsilon(1e-14));
}

TEST_CASE("mlp: parameter gradients match finite differences", "[mlp]") {
  for (auto act : {atacom::Activation::Relu, atacom::Activation::Tanh, atacom::Activation::Softplus}) {
    Mlp<double> net(3, 2, MlpConfig{{6, 5}, act}, 2);
    Rng rng(2, 0);
    net.init(rng);
    for (auto& p : net.params()) p += 0.01;  // nonzero biases keep ReLU away from kinks at zero input
    std::vector<double> x(4 * 3);
    for (auto& v : x) v = rng.uniform(-1, 1);
    atacom::Tape<double> t;
    auto loss = [&](bool grad) {
      t.clear();
      const auto y = net.forward(t, t.constant(x.data(), 4, 3), grad);
      const auto l = t.mean(t.square(y));
      if (grad) t.backward(l);
      return t.scalar(l);
    };
    net.zero_grad();
    loss(true);
    const auto g = net.grads();
    for (size_t k = 0; k < net.params().size(); k += 3) {
      const double p0 = net.params()[k];
      net.params()[k] = p0 + 1e-6;
      const double fp = loss(false);
      net.params()[k] = p0 - 1e-6;
      const double fm = loss(false);
      net.params()[k] = p0;
      REQUIRE(g[k] == Approx((fp - fm) / 2e-6).margin(1e-7));
    }
  }
}

TEST_CASE("mlp: Xavier-uniform bounds with the activation's gain", "[mlp]") {
  Mlp<float> net(20, 256, MlpConfig{{256}, atacom::Activation::Relu}, 1);
  Rng rng(3, 0);
  net.init(rng);
  const double bound = std::sqrt(2.0) * std::sqrt(6.0 / (20 + 256));
  double mx = 0;
  for (int k = 0; k < 20 * 256; ++k) mx = std::max(mx, double(std::abs(net.params()[size_t(k)])));
  REQUIRE(mx <= bound);
  REQUIRE(mx > 0.95 * bound);
  REQUIRE(net.params()[20 * 256] == 0.0f);  // first bias
}

TEST_CASE("mlp: config JSON round trip and strict parsing", "[mlp]") {
  MlpConfig c = atacom::default_mlp_config();
  REQUIRE(c.hidden == std::vector<int>{256, 256});
  c.hidden = {64, 32};
  c.activation = atacom::Activation::Sigmoid;
  const MlpConfig back = nlohmann::json(c).get<MlpConfig>();
  REQUIRE(back.hidden == c.hidden);
  REQUIRE(back.activation == c.activation);
  REQUIRE_THROWS_WITH((nlohmann::json{{"hiden", {3}}}.get<MlpConfig>()), Catch::Contains("mlp.hiden"));
  REQUIRE_THROWS_WITH((nlohmann::json{{"activation", "gelu"}}.get<MlpConfig>()), Catch::Contains("gelu"));
  REQUIRE_THROWS_WITH((nlohmann::json{{"hidden", {0}}}.get<MlpConfig>()), Catch::Contains("'mlp.hidden[0]' is 0, must be an integer in [1, 8192]"));
  REQUIRE_THROWS_WITH((nlohmann::json{{"hidden", 3}}.get<MlpConfig>()), Catch::Contains("'mlp.hidden' must be a list of 1 to 16 integers"));
}
