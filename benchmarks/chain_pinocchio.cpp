// Pinocchio 4 on the same chain as skelarm-sym's emitted code: T, J, dJ (LOCAL_WORLD_ALIGNED at the
// tool frame), twist J v and classical acceleration J a + dJ v. Reads the chain (every joint a z
// motion after a constant placement, then a constant tool placement) from the file argv[1], then
// configurations from argv[2]; prints the outputs of the first configuration and the median ns/call.
#include <pinocchio/multibody.hpp>
#include <pinocchio/algorithm/jacobian.hpp>
#include <pinocchio/algorithm/frames.hpp>
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <vector>

static pinocchio::SE3 read_placement(std::ifstream &in) {
    Eigen::Matrix3d R; Eigen::Vector3d t;
    for (int i = 0; i < 3; ++i) { for (int j = 0; j < 3; ++j) in >> R(i, j); in >> t(i); }
    return pinocchio::SE3(R, t);
}

int main(int argc, char **argv) {
    std::ifstream chain(argv[1]), configs(argv[2]);
    int joints; chain >> joints;
    pinocchio::Model model;
    pinocchio::JointIndex parent = 0;
    for (int k = 0; k < joints; ++k) {
        int prismatic; chain >> prismatic;
        pinocchio::SE3 M = read_placement(chain);
        if (prismatic) parent = model.addJoint(parent, pinocchio::JointModelPZ(), M, "j" + std::to_string(k));
        else parent = model.addJoint(parent, pinocchio::JointModelRZ(), M, "j" + std::to_string(k));
    }
    pinocchio::FrameIndex tool = model.addFrame(pinocchio::Frame("tool", parent, 0, read_placement(chain), pinocchio::OP_FRAME));
    pinocchio::Data data(model);
    int m, repeats; configs >> m >> repeats;
    const int n = model.nq;
    std::vector<Eigen::VectorXd> q(m, Eigen::VectorXd(n)), v(m, Eigen::VectorXd(n)), a(m, Eigen::VectorXd(n));
    for (int i = 0; i < m; ++i) for (int j = 0; j < n; ++j) configs >> q[i](j) >> v[i](j) >> a[i](j);
    pinocchio::Data::Matrix6x J(6, n), dJ(6, n);
    Eigen::Matrix<double, 6, 1> twist, acc;
    double sink = 0;
    auto run = [&](int i) {
        J.setZero(); dJ.setZero();
        pinocchio::computeJointJacobiansTimeVariation(model, data, q[i], v[i]);
        pinocchio::updateFramePlacement(model, data, tool);
        pinocchio::getFrameJacobian(model, data, tool, pinocchio::LOCAL_WORLD_ALIGNED, J);
        pinocchio::getFrameJacobianTimeVariation(model, data, tool, pinocchio::LOCAL_WORLD_ALIGNED, dJ);
        twist.noalias() = J * v[i];
        acc.noalias() = J * a[i];
        acc.noalias() += dJ * v[i];
        sink += twist(0) + acc(0) + data.oMf[tool].translation()(0);
    };
    run(0);
    const Eigen::Matrix4d T = data.oMf[tool].toHomogeneousMatrix();
    for (int i = 0; i < 16; ++i) std::printf("%.17g ", T(i / 4, i % 4));
    for (int r = 0; r < 6; ++r) for (int c = 0; c < n; ++c) std::printf("%.17g ", J(r, c));
    for (int r = 0; r < 6; ++r) for (int c = 0; c < n; ++c) std::printf("%.17g ", dJ(r, c));
    for (int r = 0; r < 6; ++r) std::printf("%.17g ", twist(r));
    for (int r = 0; r < 6; ++r) std::printf("%.17g ", acc(r));
    std::printf("\n");
    std::vector<double> samples;
    for (int rep = 0; rep < repeats; ++rep) {
        auto start = std::chrono::steady_clock::now();
        for (int i = 0; i < m; ++i) run(i);
        auto stop = std::chrono::steady_clock::now();
        samples.push_back(std::chrono::duration<double, std::nano>(stop - start).count() / m);
    }
    std::sort(samples.begin(), samples.end());
    std::printf("%.2f %g\n", samples[samples.size() / 2], sink);
    return 0;
}
