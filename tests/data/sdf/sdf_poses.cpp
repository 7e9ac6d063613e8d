// Reads an SDFormat file with libsdformat and prints what tests/calibration/test_export_sdf.py composes the
// forward kinematics from: the load errors, then the model's pose and, through the semantic pose
// API, every link, joint and frame resolved in the model frame (the zero configuration), each
// joint's type, parent, child, axis resolved in the joint's own frame and limits.
//   model X Y Z QW QX QY QZ
//   link NAME X Y Z QW QX QY QZ
//   joint NAME TYPE PARENT CHILD X Y Z QW QX QY QZ AX AY AZ LOWER UPPER
//   frame NAME ATTACHED_TO X Y Z QW QX QY QZ
//   error TEXT
// Built against libsdformat 12 (Debian's libsdformat-dev); the API used is the same in 13 and 14.
#include <cstdio>
#include <string>

#include <sdf/Frame.hh>
#include <sdf/Joint.hh>
#include <sdf/JointAxis.hh>
#include <sdf/Link.hh>
#include <sdf/Model.hh>
#include <sdf/Root.hh>

namespace {

template <typename Pose>
void print_pose(const Pose &pose) {
  std::printf(" %.17g %.17g %.17g %.17g %.17g %.17g %.17g", pose.Pos().X(), pose.Pos().Y(),
              pose.Pos().Z(), pose.Rot().W(), pose.Rot().X(), pose.Rot().Y(), pose.Rot().Z());
}

bool report(const sdf::Errors &errors) {
  for (const auto &error : errors) {
    std::printf("error %s\n", error.Message().c_str());
  }
  return errors.empty();
}

const char *type_name(sdf::JointType type) {
  switch (type) {
    case sdf::JointType::FIXED: return "fixed";
    case sdf::JointType::REVOLUTE: return "revolute";
    case sdf::JointType::CONTINUOUS: return "continuous";
    case sdf::JointType::PRISMATIC: return "prismatic";
    default: return "other";
  }
}

}  // namespace

int main(int argc, char **argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s FILE.sdf\n", argv[0]);
    return 2;
  }
  sdf::Root root;
  if (!report(root.Load(argv[1]))) return 1;
  const sdf::Model *model = root.Model();
  if (model == nullptr) {
    std::printf("error no model\n");
    return 1;
  }
  std::printf("model");
  print_pose(model->RawPose());
  std::printf("\n");
  bool ok = true;
  for (uint64_t i = 0; i < model->LinkCount(); ++i) {
    const sdf::Link *link = model->LinkByIndex(i);
    ignition::math::Pose3d pose;
    ok = report(link->SemanticPose().Resolve(pose, "__model__")) && ok;
    std::printf("link %s", link->Name().c_str());
    print_pose(pose);
    std::printf("\n");
  }
  for (uint64_t i = 0; i < model->JointCount(); ++i) {
    const sdf::Joint *joint = model->JointByIndex(i);
    ignition::math::Pose3d pose;
    ok = report(joint->SemanticPose().Resolve(pose, "__model__")) && ok;
    ignition::math::Vector3d xyz(0, 0, 0);
    double lower = 0, upper = 0;
    const sdf::JointAxis *axis = joint->Axis(0);
    if (axis != nullptr) {
      ok = report(axis->ResolveXyz(xyz, joint->Name())) && ok;
      lower = axis->Lower();
      upper = axis->Upper();
    }
    std::printf("joint %s %s %s %s", joint->Name().c_str(), type_name(joint->Type()),
                joint->ParentLinkName().c_str(), joint->ChildLinkName().c_str());
    print_pose(pose);
    std::printf(" %.17g %.17g %.17g %.17g %.17g\n", xyz.X(), xyz.Y(), xyz.Z(), lower, upper);
  }
  for (uint64_t i = 0; i < model->FrameCount(); ++i) {
    const sdf::Frame *frame = model->FrameByIndex(i);
    ignition::math::Pose3d pose;
    ok = report(frame->SemanticPose().Resolve(pose, "__model__")) && ok;
    std::printf("frame %s %s", frame->Name().c_str(), frame->AttachedTo().c_str());
    print_pose(pose);
    std::printf("\n");
  }
  return ok ? 0 : 1;
}
