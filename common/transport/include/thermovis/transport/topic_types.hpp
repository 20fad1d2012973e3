#pragma once
// The generated IDL types and their Fast DDS type supports: TypeSupportOf<T>::type is the
// generated PubSubType of T.
#include <fastdds/dds/topic/TypeSupport.hpp>

#include "thermovis/commonPubSubTypes.h"
#include "thermovis/framesPubSubTypes.h"
#include "thermovis/geometryPubSubTypes.h"
#include "thermovis/healthPubSubTypes.h"
#include "thermovis/obstaclesPubSubTypes.h"
#include "thermovis/perceptionPubSubTypes.h"

namespace thermovis::transport {

template <class T>
struct TypeSupportOf;

#define THERMOVIS_TYPE_SUPPORT(TYPE)            \
  template <>                                   \
  struct TypeSupportOf<::thermovis::TYPE> {     \
    using type = ::thermovis::TYPE##PubSubType; \
  }

THERMOVIS_TYPE_SUPPORT(VisibleStereoFrame);
THERMOVIS_TYPE_SUPPORT(InfraredStereoFrame);
THERMOVIS_TYPE_SUPPORT(GridStereoFrame);
THERMOVIS_TYPE_SUPPORT(PackedStereoFrame);
THERMOVIS_TYPE_SUPPORT(GridGeometry);
THERMOVIS_TYPE_SUPPORT(DetectionArray);
THERMOVIS_TYPE_SUPPORT(MatchArray);
THERMOVIS_TYPE_SUPPORT(RangeArray);
THERMOVIS_TYPE_SUPPORT(FrameTiming);
THERMOVIS_TYPE_SUPPORT(Health);
THERMOVIS_TYPE_SUPPORT(ObstacleArray);

#undef THERMOVIS_TYPE_SUPPORT

template <class T>
eprosima::fastdds::dds::TypeSupport make_type_support() {
  return eprosima::fastdds::dds::TypeSupport(new typename TypeSupportOf<T>::type());
}

// True for types Fast DDS can loan and deliver by data-sharing without serialisation.
template <class T>
bool is_plain_type() {
  return typename TypeSupportOf<T>::type().is_plain();
}

}  // namespace thermovis::transport
